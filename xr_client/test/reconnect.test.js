// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ReconnectPolicy, PING_PERIOD_MS, PONG_TIMEOUT_MS } from '../src/reconnect.js';
import { accessRefusal } from '../src/connection.js';
import { operatorToken, relayUrl } from '../src/connection.js';

test('the relay address comes from the page origin, ws or wss to match', () => {
  assert.equal(relayUrl(new URL('http://127.0.0.1:8090/index.html')), 'ws://127.0.0.1:8090/ws?batch=1');
  assert.equal(relayUrl(new URL('https://relay.example:8443/?emulate=quest3')), 'wss://relay.example:8443/ws?batch=1');
  assert.equal(relayUrl(new URL('http://127.0.0.1:8080/'), 'a b+c'), 'ws://127.0.0.1:8080/ws?batch=1&token=a%20b%2Bc');
});

test('the operator token comes from the #token= fragment and is kept for the tab', () => {
  /** @type {Map<string, string>} */
  const store = new Map();
  const storage = {
    getItem: (/** @type {string} */ k) => store.get(k) ?? null,
    setItem: (/** @type {string} */ k, /** @type {string} */ v) => void store.set(k, v),
  };
  assert.equal(operatorToken(new URL('http://h:8080/'), storage), null);
  assert.equal(operatorToken(new URL('http://h:8080/?emulate=quest3#token=s3cret'), storage), 's3cret');
  assert.equal(operatorToken(new URL('http://h:8080/'), storage), 's3cret'); // a reload without the fragment
});

test('backoff doubles up to a cap, with a visible countdown', () => {
  const p = new ReconnectPolicy({ first: 500, max: 5000 });
  p.connecting(0);
  assert.equal(p.describe(0), 'connecting…');
  assert.equal(p.closed(100), 500);
  assert.equal(p.describe(100), 'disconnected · reconnecting in 1 s');
  const delays = [1000, 2000, 4000, 5000, 5000].map((_, i) => (p.connecting(1000 * i), p.closed(1000 * i + 1)));
  assert.deepEqual(delays, [1000, 2000, 4000, 5000, 5000]);
  p.retryAt = 10_000;
  assert.match(p.describe(6_900), /^cannot connect · reconnecting in 4 s · open the address the relay printed/);
  p.opened(11_000);
  p.closed(11_500);
  assert.equal(p.describe(11_600), 'disconnected · reconnecting in 5 s');
});

test('a connection that lasted resets the backoff; latency from ping/pong', () => {
  const p = new ReconnectPolicy({ first: 500, max: 5000 });
  p.connecting(0);
  p.closed(0);
  p.closed(0);
  p.connecting(0);
  p.opened(1000);
  p.pong(1000, 1040);
  assert.equal(p.describe(1050), 'connected · 40 ms');
  p.pong(2000, 2020);
  assert.equal(Math.round(/** @type {number} */ (p.latency)), 34);
  assert.equal(p.stale(2020 + PONG_TIMEOUT_MS - 1), false);
  assert.equal(p.stale(2020 + PONG_TIMEOUT_MS + 1), true);
  assert.equal(p.closed(20_000), 500);
  assert.equal(p.latency, null);
});

test("a page that could not listen (a long frame) does not count that time as the relay's silence", () => {
  const p = new ReconnectPolicy();
  p.connecting(0);
  p.opened(0);
  assert.equal(p.stale(PING_PERIOD_MS), false);
  // The page's thread is busy for 8 s: the pongs of that time wait behind this check.
  assert.equal(p.stale(PING_PERIOD_MS + 8000), false);
  p.pong(PING_PERIOD_MS, PING_PERIOD_MS + 8001);
  // A relay that then falls silent while the page checks on time is found out after PONG_TIMEOUT_MS of it.
  let now = PING_PERIOD_MS + 8001;
  const silentFrom = now;
  while (!p.stale((now += PING_PERIOD_MS)));
  assert.ok(now - silentFrom > PONG_TIMEOUT_MS && now - silentFrom <= PONG_TIMEOUT_MS + PING_PERIOD_MS, `${now}`);
  // Silent on time from the start: as before.
  const q = new ReconnectPolicy();
  q.connecting(0);
  q.opened(0);
  for (let t = PING_PERIOD_MS; t <= PONG_TIMEOUT_MS; t += PING_PERIOD_MS) assert.equal(q.stale(t), false);
  assert.equal(q.stale(PONG_TIMEOUT_MS + PING_PERIOD_MS), true);
});

test('a refused token stops the retries and says what to do', () => {
  const p = new ReconnectPolicy();
  p.connecting(0);
  p.closed(50);
  p.refused('wrong operator token');
  assert.equal(p.state, 'refused');
  assert.equal(p.retryAt, null);
  assert.equal(
    p.describe(5_000),
    'refused: wrong operator token · open the address the relay printed (…/#token=…) and reload',
  );
});

test('accessRefusal asks the relay why, and only a refusal stops the retries', async () => {
  const where = new URL('http://127.0.0.1:8080/#token=stale');
  /** @type {{url: string, body: unknown}[]} */
  const asked = [];
  /** @param {number} status @param {string} text */
  const answer = (status, text) =>
    /** @type {typeof fetch} */ (
      async (url, init) => {
        asked.push({ url: String(url), body: init?.body });
        return new Response(text, { status });
      }
    );
  assert.equal(await accessRefusal(where, 'stale', answer(401, 'wrong operator token\n')), 'wrong operator token');
  assert.deepEqual(asked[0], { url: 'http://127.0.0.1:8080/auth', body: 'stale' });
  assert.equal(await accessRefusal(where, 'good', answer(200, '{"role": "operator"}')), null);
  assert.equal(await accessRefusal(where, null, answer(403, 'origin x is not allowed')), 'origin x is not allowed');
  const unreachable = /** @type {typeof fetch} */ (
    async () => {
      throw new TypeError('Failed to fetch');
    }
  );
  assert.equal(await accessRefusal(where, 'good', unreachable), null);
});
