// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ClockSync, Latency, LATENCY_OK_MS, LATENCY_SLOW_MS, latencyColour, latencyParts } from '../src/latency.js';

/** @param {number | null} actual @param {number} expected */
function near(actual, expected) {
  assert.ok(actual !== null && Math.abs(actual - expected) < 0.1, `${actual} is not ${expected}`);
}

/** A page whose clock reads 0 when the relay's reads `relayAtZero` (s), pinged over a link of `rtt` ms. */
function synced(relayAtZero, rtt, at = 1000) {
  const clock = new ClockSync();
  clock.pong(at, at + rtt, relayAtZero + (at + rtt / 2) / 1000);
  return clock;
}

test('the clock mapping takes the quickest ping, and its error is half that round trip', () => {
  const clock = new ClockSync();
  assert.equal(clock.relayTime(0), null);
  // A slow ping whose answer was held 400 ms on the way back: its midpoint is 200 ms off.
  clock.pong(1000, 1600, 5000 + 1.1);
  clock.pong(3000, 3010, 5000 + 3.005); // a quick one, symmetric
  assert.ok(Math.abs(/** @type {number} */ (clock.relayTime(4000)) - 5004) < 1e-9);
  assert.equal(clock.error, 5);
});

test("a picture's latency is its publisher's stamp to its decoding, the median of the recent ones", () => {
  const latency = new Latency(synced(1_700_000_000, 8));
  // Decoded at page time 10 s, i.e. relay 1_700_000_010 s; stamped 80, 90 and 600 ms earlier.
  for (const late of [0.08, 0.09, 0.6]) latency.picture('robot1', 1_700_000_010 - late, 10_000);
  // The median: one late picture does not make the number jump (to a float's precision at 1.7e9 s: 0.1 ms).
  near(latency.of('robot1').picture, 90);
  assert.equal(latency.of('robot2').picture, null);
  assert.equal(latency.of('robot1').pose, null);
});

test('stamps from a clock that does not compare give no number rather than a wrong one', () => {
  const latency = new Latency(synced(1_700_000_000, 8));
  latency.pose('robot1', 1_600_000_000, 10_000); // a recording's stamp: a hundred million seconds old
  latency.pose('robot1', 1_700_000_011, 10_000); // a robot clock a second ahead
  assert.equal(latency.of('robot1').pose, null);
  latency.pose('robot1', 1_700_000_010.1, 10_000); // 100 ms ahead: within the mapping's error, shown as 0
  assert.equal(latency.of('robot1').pose, 0);
  const unsynced = new Latency(new ClockSync());
  unsynced.pose('robot1', 1_700_000_010, 10_000); // no pong yet: nothing to compare with
  assert.equal(unsynced.of('robot1').pose, null);
});

test('samples are mapped by the best ping when read: a quicker ping later corrects those taken before it', () => {
  const clock = new ClockSync();
  const latency = new Latency(clock);
  latency.pose('robot1', 1_700_000_010, 10_000); // before any pong: kept, not yet a number
  assert.equal(latency.of('robot1').pose, null);
  // A slow ping held 600 ms on its way out: the mapping is 300 ms ahead, and everything seems that much older.
  clock.pong(1000, 1600, 1_700_000_000 + 1.6);
  for (const late of [0.04, 0.05, 0.06]) latency.picture('robot1', 1_700_000_010 - late, 10_000);
  near(latency.of('robot1').picture, 350);
  clock.pong(3000, 3010, 1_700_000_000 + 3.005); // a quick symmetric one: the true mapping
  near(latency.of('robot1').picture, 50);
  near(latency.of('robot1').pose, 0);
});

test('a command round trip is from sending to its answer; unanswered ones are forgotten, bounded', () => {
  const latency = new Latency(new ClockSync());
  latency.sent('7', 'robot2', 1000);
  latency.answered('7', 1042);
  latency.answered('7', 1100); // answered twice (an ack then an error): counted once
  latency.answered('unknown', 1100);
  assert.equal(latency.of('robot2').command, 42);
  for (let i = 0; i < 200; i++) latency.sent(`x${i}`, 'robot2', i);
  assert.ok(latency.pending.size <= 64);
  latency.reset();
  assert.equal(latency.pending.size, 0);
});

test('figures are coloured by how late they are, and only measured stages are written', () => {
  assert.equal(latencyColour(LATENCY_OK_MS - 1), '#5ad17a');
  assert.equal(latencyColour(LATENCY_OK_MS), '#ffb020');
  assert.equal(latencyColour(LATENCY_SLOW_MS), '#ff5a5a');
  assert.deepEqual(latencyParts({ pose: 35.4, picture: null, command: 1234 }), [
    { stage: 'pose', text: 'pose 35 ms', colour: '#5ad17a' },
    { stage: 'command', text: 'command 1.2 s', colour: '#ff5a5a' },
  ]);
});
