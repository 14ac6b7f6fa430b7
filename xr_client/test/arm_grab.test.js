// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  ArmGrab,
  FOLLOW_GAIN,
  GRAB_RADIUS,
  GRIP_PERIOD_MS,
  GRIP_REFRESH_MS,
  GripperTrigger,
  HAND_SCALE,
} from '../src/arm_grab.js';

/** @type {[number, number, number]} */
const TIP = [0.07, 0, 0.29];

/** @param {number[]} a @param {number[]} b */
const close = (a, b) => a.forEach((v, i) => assert.ok(Math.abs(v - b[i]) < 1e-9, `${a} != ${b}`));

test('a squeeze near the gripper takes the arm; one away from it, or by a second hand, does not', () => {
  const grab = new ArmGrab();
  assert.equal(grab.squeeze(0, [TIP[0] + GRAB_RADIUS + 0.01, 0, TIP[2]], TIP), false);
  assert.equal(grab.squeeze(0, [TIP[0] + 0.05, 0, TIP[2]], TIP), true);
  assert.equal(grab.squeeze(1, TIP, TIP), false);
  assert.deepEqual(grab.follow([TIP[0] + 0.05, 0, TIP[2]], TIP), [0, 0, 0]); // the hand has not moved
});

test('the tip follows the hand from where the squeeze began, scaled down', () => {
  const grab = new ArmGrab();
  grab.squeeze(0, [0.1, 0, 0.3], TIP);
  // The hand 10 cm up: the tip should go 5 cm up; it is still where it was.
  close(grab.follow([0.1, 0, 0.4], TIP), [0, 0, FOLLOW_GAIN * HAND_SCALE * 0.1]);
  // Halfway there, half the speed; there, none.
  close(grab.follow([0.1, 0, 0.4], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, FOLLOW_GAIN * 0.025]);
  assert.deepEqual(grab.follow([0.1, 0, 0.4], [TIP[0], 0, TIP[2] + 0.05]), [0, 0, 0]);
});

test('letting go releases the arm (only the hand that holds it), and then nothing moves it', () => {
  const grab = new ArmGrab();
  grab.squeeze(1, TIP, TIP);
  assert.equal(grab.release(0), false);
  assert.equal(grab.release(1), true);
  assert.deepEqual(grab.follow([1, 1, 1], TIP), [0, 0, 0]);
  assert.equal(grab.held, null);
});

test('with 1:1 the tip follows the whole motion, and the change takes the arm again where it is', () => {
  const grab = new ArmGrab();
  grab.squeeze(0, [0.1, 0, 0.3], TIP);
  grab.setScale(1, [0.1, 0, 0.35], [TIP[0], 0, TIP[2] + 0.025]);
  // No jump: where the hand and the tip were at the change is the new start.
  assert.deepEqual(grab.follow([0.1, 0, 0.35], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, 0]);
  close(grab.follow([0.1, 0, 0.45], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, FOLLOW_GAIN * 0.1]);
  grab.setScale(HAND_SCALE, null, null); // back to half (nothing to take again with)
  assert.equal(grab.scale, HAND_SCALE);
});

test("the trigger's travel is the gripper's, open to closed, at most 10 a second, never lost to the rate or a drop", () => {
  const trigger = new GripperTrigger();
  const range = [0.01, -0.01]; // OpenManipulator-X's SRDF: open, close
  assert.equal(trigger.update(0, range, -200), 0.01); // the hand takes the arm, its trigger at rest: open
  assert.equal(trigger.update(0, range, 0), null); // still at rest: nothing more
  assert.equal(trigger.update(0.02, range, 10), null); // a tremor
  const half = trigger.update(0.5, range, 20);
  assert.ok(half !== null && Math.abs(half) < 1e-12);
  assert.equal(trigger.update(1, range, 20 + GRIP_PERIOD_MS - 1), null); // too soon...
  assert.equal(trigger.update(1, range, 20 + GRIP_PERIOD_MS), -0.01); // ...then it goes
  const closed = 20 + GRIP_PERIOD_MS;
  assert.equal(trigger.update(1, range, 500), null); // held: once...
  assert.equal(trigger.update(0.98, range, 600), null);
  assert.equal(trigger.update(1, range, closed + GRIP_REFRESH_MS), -0.01); // ...and again a second later
  assert.equal(trigger.update(0, range, closed + GRIP_REFRESH_MS + 100), 0.01); // let go: open again
  assert.equal(trigger.update(1, [], 900), null); // no gripper
  trigger.reset(); // let go: the next hold sets it afresh
  assert.equal(trigger.update(0.7, range, 1000), 0.01 + 0.7 * -0.02);
});
