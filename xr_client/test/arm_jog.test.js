// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ArmJog, ArmSender, ARM_PERIOD_MS, JOG_SPEED, approach, keysToArmTwist } from '../src/arm_jog.js';

/** @type {[number, number, number]} */
const NONE = [0, 0, 0];

test('I/K, J/L and U/O move the tip along x, y and z of the arm base; opposite keys cancel', () => {
  assert.deepEqual(keysToArmTwist(['KeyI']), [JOG_SPEED, 0, 0]);
  assert.deepEqual(keysToArmTwist(['KeyL', 'KeyO']), [0, -JOG_SPEED, -JOG_SPEED]);
  assert.deepEqual(keysToArmTwist(['KeyU', 'KeyO', 'KeyW']), [0, 0, 0]);
});

test('twists at the teleop rate while keys are held, one zero on release, silence after', () => {
  const jog = new ArmJog();
  /** @type {import('../src/arm_jog.js').ArmTwist[]} */
  const sent = [];
  for (let t = 0; t < 1000; t += 10) sent.push(...jog.update('robot3', [0.05, 0, 0], NONE, t)); // the 100 Hz timer
  assert.equal(sent.length, 1000 / ARM_PERIOD_MS);
  assert.ok(sent.every((c) => c.robot === 'robot3' && c.linear[0] === 0.05));
  const released = jog.update('robot3', [0, 0, 0], NONE, 1000);
  assert.deepEqual(released, [{ robot: 'robot3', linear: [0, 0, 0], angular: [0, 0, 0] }]);
  for (let t = 1010; t < 2000; t += 10) assert.deepEqual(jog.update('robot3', [0, 0, 0], NONE, t), []);
});

test('a change of direction goes with the next beat: never more than 20 twists a second', () => {
  const jog = new ArmJog();
  jog.update('robot3', [0.05, 0, 0], NONE, 0);
  assert.deepEqual(jog.update('robot3', [0, 0, 0.05], NONE, 10), []);
  assert.deepEqual(jog.update('robot3', [0, 0.01, 0.05], NONE, 50)[0].linear, [0, 0.01, 0.05]);
  let sent = 0;
  for (let t = 60; t < 1060; t += 1000 / 90) sent += jog.update('robot3', [0, 0, 0.05 + t * 1e-6], NONE, t).length;
  assert.ok(sent <= 20, `${sent} twists in a second of 90 Hz frames`);
});

test('losing the arm (deselected, held by another, E-STOP) stops it with one zero', () => {
  const jog = new ArmJog();
  jog.update('robot3', [0, 0.05, 0], NONE, 0);
  assert.deepEqual(jog.update(null, [0, 0.05, 0], NONE, 20), [{ robot: 'robot3', linear: NONE, angular: NONE }]);
  assert.deepEqual(jog.update(null, [0, 0.05, 0], NONE, 100), []);
  jog.update('robot3', [0, 0.05, 0], NONE, 200);
  assert.equal(jog.stop(210).length, 1);
  assert.deepEqual(jog.stop(220), []);
});

test('the drawn arm approaches the newest joint state smoothly, and takes a new shape at once', () => {
  const current = [[0, 0, 0]];
  approach(current, [[1, 0, 0]], 0.06, 0.06);
  assert.ok(Math.abs(current[0][0] - (1 - Math.exp(-1))) < 1e-9);
  approach(current, [[1, 0, 0]], 10, 0.06);
  assert.ok(Math.abs(current[0][0] - 1) < 1e-9);
  approach(
    current,
    [
      [0, 0, 0],
      [0, 0, 1],
    ],
    0.01,
  );
  assert.deepEqual(current, [
    [0, 0, 0],
    [0, 0, 1],
  ]);
});

test('twists go without an id (dropped while disconnected); the gripper gets one, or says it was not sent', () => {
  /** @type {[Record<string, unknown>, boolean | undefined][]} */
  const sent = [];
  let connected = true;
  /** @type {string[]} */
  const said = [];
  const link = {
    send: (/** @type {Record<string, unknown>} */ m, /** @type {boolean | undefined} */ withId) =>
      connected ? (sent.push([m, withId]), 'c1') : null,
  };
  const arm = new ArmSender(link, (text) => said.push(text));
  arm.twist({ robot: 'robot3', linear: [0.05, 0, 0], angular: [0, 0, 0] });
  arm.twist({ robot: 'robot3', linear: [0, 0, 0], angular: [0, 0, 0.2] }, 'tip');
  assert.equal(arm.gripper('robot3', 'close'), 'c1');
  assert.equal(arm.gripper('robot3', -0.005), 'c1'); // a trigger's position
  assert.deepEqual(sent, [
    [{ identifier: 'robot3/arm/twist', linear: [0.05, 0, 0], angular: [0, 0, 0] }, false],
    [{ identifier: 'robot3/arm/twist', linear: [0, 0, 0], angular: [0, 0, 0.2], frame: 'tip' }, false],
    [{ identifier: 'robot3/arm/gripper', state: 'close' }, undefined],
    [{ identifier: 'robot3/arm/gripper', position: -0.005 }, undefined],
  ]);
  connected = false;
  arm.twist({ robot: 'robot3', linear: [0.05, 0, 0], angular: [0, 0, 0] });
  assert.equal(arm.gripper('robot3', 'open'), null);
  assert.deepEqual(said, ['not connected: robot3/arm/gripper not sent']);
});
