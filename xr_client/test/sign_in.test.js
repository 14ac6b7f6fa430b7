import { test } from 'node:test';
import assert from 'node:assert/strict';

import { claimCode, CSRF_HEADER, pairingCode, signIn, signOut, whoAmI } from '../src/sign_in.js';

/** A relay's answers by path, and every request the page made. */
function relay(answers) {
  const asked = [];
  const fetcher = async (url, init = {}) => {
    const path = new URL(url).pathname;
    asked.push({ path, init });
    const [status, body] = answers[path] ?? [404, 'no such route'];
    return {
      ok: status >= 200 && status < 300,
      status,
      json: async () => body,
      text: async () => (typeof body === 'string' ? body : JSON.stringify(body)),
    };
  };
  return { fetcher, asked };
}

const ORIGIN = 'http://127.0.0.1:8080';
const ANA = { user: 'Ana', role: 'operator', csrf: 'tok-1' };

test('a page asks who it is: an account, signed out, or a relay without accounts', async () => {
  /** @param {Record<string, [number, any]>} answers */
  const who = async (answers) => (await whoAmI(ORIGIN, relay(answers).fetcher)).account;
  assert.deepEqual(await who({ '/whoami': [200, { accounts: true, ...ANA }] }), ANA);
  assert.equal(await who({ '/whoami': [200, { accounts: true, user: null }] }), null);
  // No accounts: the operator token, as before (also an older relay without the route).
  assert.equal(await who({ '/whoami': [200, { accounts: false }] }), undefined);
  assert.equal(await who({}), undefined);
  const broken = async () => {
    throw new TypeError('network');
  };
  assert.deepEqual(await whoAmI(ORIGIN, broken), { account: undefined, provider: null });
});

test("the site's sign-in provider is offered when the relay names one, and only then", async () => {
  const issuer = 'https://id.site.example/realms/plant';
  const signedOut = { accounts: true, user: null };
  /** @param {Record<string, [number, any]>} answers */
  const provider = async (answers) => (await whoAmI(ORIGIN, relay(answers).fetcher)).provider;
  assert.equal(await provider({ '/whoami': [200, { ...signedOut, oidc: issuer }] }), issuer);
  assert.equal(await provider({ '/whoami': [200, { ...signedOut, oidc: null }] }), null);
  assert.equal(await provider({}), null);
});

test('signing in sends JSON and takes the account; a refusal is the relay own words', async () => {
  const good = relay({ '/signin': [200, ANA] });
  assert.deepEqual(await signIn(ORIGIN, '  Ana ', 'secret-password', good.fetcher), { ok: true, account: ANA });
  assert.deepEqual(JSON.parse(good.asked[0].init.body), { user: 'Ana', password: 'secret-password' });
  const bad = relay({ '/signin': [401, 'wrong user name or password\n'] });
  assert.deepEqual(await signIn(ORIGIN, 'Ana', 'nope', bad.fetcher), {
    ok: false,
    reason: 'wrong user name or password',
  });
  const empty = relay({});
  assert.equal((await signIn(ORIGIN, ' ', '', empty.fetcher)).ok, false);
  assert.equal(empty.asked.length, 0); // nothing sent for an empty form
  const odd = relay({ '/signin': [200, { user: 'Ana', role: 'root', csrf: 'x' }] });
  assert.equal((await signIn(ORIGIN, 'Ana', 'pw-long-enough', odd.fetcher)).ok, false); // an unknown role is no account
});

test('a pairing code is typed loosely, asked with the CSRF token, and sign-out carries it too', async () => {
  const headset = relay({ '/pair/claim': [200, { ...ANA, csrf: 'tok-2' }] });
  const claimed = await claimCode(ORIGIN, 'ab3-k7q ', headset.fetcher);
  assert.equal(claimed.ok, true);
  assert.deepEqual(JSON.parse(headset.asked[0].init.body), { code: 'AB3K7Q' });
  assert.equal((await claimCode(ORIGIN, 'AB3', headset.fetcher)).ok, false);
  const desktop = relay({
    '/pair': [200, { code: 'AB3K7Q', expires_in: 120 }],
    '/signout': [200, { signed_out: 'Ana' }],
  });
  assert.deepEqual(await pairingCode(ORIGIN, ANA, desktop.fetcher), { ok: true, code: 'AB3K7Q', expiresIn: 120 });
  assert.equal(desktop.asked[0].init.headers[CSRF_HEADER], 'tok-1');
  assert.equal(await signOut(ORIGIN, ANA, desktop.fetcher), true);
  assert.equal(desktop.asked[1].init.headers[CSRF_HEADER], 'tok-1');
});
