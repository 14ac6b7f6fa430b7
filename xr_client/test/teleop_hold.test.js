// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { HOLD_MS, TeleopHold, stampedText } from '../src/teleop_hold.js';
import { CommandSender, twistFields } from '../src/command_sender.js';

const forward = { identifier: 'robot2/cmd_vel', linear: 0.6, angular: 0 };

/**
 * Run the worker's clock as its timer would (waking at `wakeAt`) from `from` to `to`, with the page confirming its
 * command at `confirmations` (ms); returns [time, command] of everything sent and the expiries.
 * @param {TeleopHold} hold @param {number} from @param {number} to @param {number[]} confirmations
 */
function run(hold, from, to, confirmations) {
  /** @type {[number, import('../src/teleop_hold.js').HeldCommand][]} */
  const sent = [];
  /** @type {import('../src/teleop_hold.js').Expiry[]} */
  const expiries = [];
  const pending = confirmations.filter((t) => t >= from && t <= to).sort((a, b) => a - b);
  let now = from;
  for (;;) {
    const wake = hold.wakeAt();
    const next = Math.min(wake ?? Infinity, pending[0] ?? Infinity);
    if (next > to) break;
    now = Math.max(now, next);
    if (pending[0] === next) {
      pending.shift();
      hold.hold(forward, hold.epoch, now);
      continue;
    }
    const { send, expired } = hold.tick(now);
    for (const c of send) sent.push([now, c]);
    if (expired) expiries.push(expired);
  }
  return { sent, expiries };
}

test('the worker repeats the held command at 20 Hz whatever the page confirms at (3 frames a second)', () => {
  const hold = new TeleopHold();
  hold.hold(forward, 0, 0); // the page sent the first command itself at 0
  const frames = Array.from({ length: 11 }, (_, k) => 300 * (k + 1));
  const { sent, expiries } = run(hold, 0, 3000, frames);
  // Repeats at 50, 100, ... 3000: 60 in 3 s, never a burst, all the held command.
  assert.equal(sent.length, 60);
  assert.deepEqual(
    sent.map(([t]) => t),
    Array.from({ length: 60 }, (_, k) => 50 * (k + 1)),
  );
  assert.ok(sent.every(([, c]) => c === hold.held || c.linear === 0.6));
  assert.deepEqual(expiries, []);
});

test('a late timer does not burst: the cadence restarts from the late tick', () => {
  const hold = new TeleopHold();
  hold.hold(forward, 0, 0);
  assert.equal(hold.tick(50).send.length, 1);
  assert.equal(hold.tick(400).send.length, 1); // the worker itself was held up 300 ms: one command, not seven
  assert.deepEqual(hold.tick(420).send, []);
  assert.equal(hold.wakeAt(), 450);
});

test('unconfirmed for the hold bound: one zero, an expiry, then silence', () => {
  assert.equal(HOLD_MS, 1500); // the slowest frames measured under SwiftShader, with a margin (teleop_hold.js)
  const hold = new TeleopHold({ bound: 1000 });
  hold.hold(forward, 0, 0);
  const { sent, expiries } = run(hold, 0, 5000, [250, 500]); // the page froze after its frame at 500 ms
  const zeros = sent.filter(([, c]) => c.linear === 0 && c.angular === 0);
  assert.deepEqual(zeros, [[1500, { identifier: 'robot2/cmd_vel', linear: 0, angular: 0 }]]);
  assert.equal(sent.at(-1)?.[0], 1500, 'nothing after the zero');
  assert.equal(sent.length, 30); // 50 ... 1450 then the zero: moving at most HOLD_MS after the last confirmation
  assert.deepEqual(expiries, [{ identifier: 'robot2/cmd_vel', silent: 1000, epoch: 1 }]);
  assert.equal(hold.wakeAt(), null);
});

test('after an expiry, confirmations of the old epoch are stale; a null always stops; the new epoch drives', () => {
  const hold = new TeleopHold({ bound: 1000 });
  hold.hold(forward, 0, 0);
  hold.tick(1000);
  assert.equal(hold.epoch, 1);
  hold.hold(forward, 0, 1100); // posted by a page that had not heard of the expiry yet
  assert.equal(hold.held, null);
  assert.deepEqual(hold.tick(1200).send, []);
  hold.hold(forward, 1, 1300);
  hold.hold(null, 0, 1310); // a stop is never stale
  assert.equal(hold.held, null);
  hold.hold(forward, 1, 1400);
  assert.equal(hold.wakeAt(), 1450);
});

test('a new value keeps the cadence; another robot starts a new one; a dropped socket repeats nothing', () => {
  const hold = new TeleopHold();
  hold.hold(forward, 0, 0);
  hold.hold({ ...forward, angular: 0.3 }, 0, 20);
  assert.deepEqual(hold.tick(50).send, [{ ...forward, angular: 0.3 }]);
  hold.hold({ identifier: 'robot1/cmd_vel', linear: 0.2, angular: 0 }, 0, 60);
  assert.equal(hold.wakeAt(), 110);
  hold.drop();
  assert.equal(hold.wakeAt(), null);
  assert.deepEqual(hold.tick(200), { send: [], expired: null });
});

test("the worker's frames are the bytes CommandSender.twist sends", () => {
  /** @type {string[]} */
  const wire = [];
  const sender = new CommandSender(
    { send: (m) => (wire.push(JSON.stringify(m)), '') },
    () => {},
    () => 1234.4,
  );
  for (const command of [
    { robot: 'robot2', linear: 0.123456, angular: -1.8 },
    { robot: 'robot1', linear: 0, angular: 0 },
  ]) {
    sender.twist(command);
    assert.equal(stampedText(twistFields(command), 1234.4), wire.at(-1));
  }
  assert.equal(wire[0], '{"identifier":"robot2/cmd_vel","linear":0.1235,"angular":-1.8,"t":1234}');
});
