// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ArmState, REFUSAL_PULSE_MS, REFUSAL_SHOWN_MS } from '../src/arm_state.js';

/** @param {string} message @param {string} [code] @returns {import('../src/protocol.js').ErrorMessage} */
const error = (message, code = 'arm_refused') => ({ identifier: 'error', id: null, code, message });
/** What relay/control/arm_control.py says of a twist refused at a joint's limit. */
const PULSE = [{ type: 'arm_refused', robot: 'robot3' }];
const AT_LIMIT = error(
  'robot3/arm/twist: refused: joint2 would come within 0.1 of its upper limit 1.571; the arm stopped where it is',
);

test("a refused twist pulses the arm's hand at most every REFUSAL_PULSE_MS, and its reason shows a while", () => {
  const arms = new ArmState();
  assert.deepEqual(arms.refused(AT_LIMIT, 1000), PULSE);
  assert.equal(arms.refusal('robot3', 1000), 'joint2 would come within 0.1 of its upper limit 1.571');
  // The hand's next twists, 20 a second, refused too: one pulse, not twenty.
  assert.deepEqual(arms.refused(AT_LIMIT, 1050), []);
  assert.deepEqual(arms.refused(AT_LIMIT, 1000 + REFUSAL_PULSE_MS - 1), []);
  assert.deepEqual(arms.refused(AT_LIMIT, 1000 + REFUSAL_PULSE_MS), PULSE);
  const last = 1000 + REFUSAL_PULSE_MS;
  assert.notEqual(arms.refusal('robot3', last + REFUSAL_SHOWN_MS - 1), null);
  assert.equal(arms.refusal('robot3', last + REFUSAL_SHOWN_MS), null);
  assert.equal(arms.refusal('robot1', last), null);
});

test("another error, or one that is not an arm's, pulses nothing and shows nothing near a gripper", () => {
  const arms = new ArmState();
  assert.deepEqual(arms.refused(error('robot3/arm/twist: robot3 runs without its arm', 'no_arm'), 0), []);
  assert.deepEqual(arms.refused(error('robot3/cmd_vel: refused', 'arm_refused'), 0), []);
  assert.equal(arms.refusals.size, 0);
  const workspace = error(
    'robot3/arm/twist: refused: the tip would leave the workspace: x 0.401 m is above its max 0.4; ' +
      'the arm stopped where it is',
  );
  assert.deepEqual(arms.refused(workspace, 0), PULSE);
  assert.equal(arms.refusal('robot3', 0), 'the tip would leave the workspace: x 0.401 m is above its max 0.4');
});

test('a new hello forgets the valve and the refusals, and the joints when the fleet changed', () => {
  const arms = new ArmState();
  arms.joints.set('robot3', /** @type {any} */ ({}));
  arms.valve = /** @type {any} */ ({ identifier: 'valve' });
  arms.refused(AT_LIMIT, 0);
  arms.hello(false);
  assert.equal(arms.joints.size, 1);
  assert.equal(arms.valve, null);
  assert.equal(arms.refusal('robot3', 0), null);
  arms.hello(true);
  assert.equal(arms.joints.size, 0);
});
