// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  ArmGrab,
  FOLLOW_GAIN,
  FOLLOW_PER_FRAME,
  GRAB_RADIUS,
  GRIP_PERIOD_MS,
  GRIP_REFRESH_MS,
  GripperTrigger,
  HAND_SCALE,
} from '../src/arm_grab.js';

/** @type {[number, number, number]} */
const TIP = [0.07, 0, 0.29];

/** @param {number[]} a @param {number[]} b */
/** A headset's frames: 72 a second (ms). */
const FRAME_MS = 1000 / 72;
/** @param {ArmGrab} grab @param {[number, number, number]} hand @param {[number, number, number]} tip */
const frame = (grab, hand, tip) => grab.follow(hand, tip, (grab.lastFollow || 0) + FRAME_MS);
const close = (a, b) => a.forEach((v, i) => assert.ok(Math.abs(v - b[i]) < 1e-9, `${a} != ${b}`));

test('a squeeze near the gripper takes the arm; one away from it, or by a second hand, does not', () => {
  const grab = new ArmGrab();
  assert.equal(grab.squeeze(0, [TIP[0] + GRAB_RADIUS + 0.01, 0, TIP[2]], TIP, 0), false);
  assert.equal(grab.squeeze(0, [TIP[0] + 0.05, 0, TIP[2]], TIP, 0), true);
  assert.equal(grab.squeeze(1, TIP, TIP, 0), false);
  assert.deepEqual(frame(grab, [TIP[0] + 0.05, 0, TIP[2]], TIP), [0, 0, 0]); // the hand has not moved
});

test('the tip follows the hand from where the squeeze began, scaled down', () => {
  const grab = new ArmGrab();
  grab.squeeze(0, [0.1, 0, 0.3], TIP, 0);
  // The hand 10 cm up: the tip should go 5 cm up; it is still where it was.
  close(frame(grab, [0.1, 0, 0.4], TIP), [0, 0, FOLLOW_GAIN * HAND_SCALE * 0.1]);
  // Halfway there, half the speed; there, none.
  close(frame(grab, [0.1, 0, 0.4], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, FOLLOW_GAIN * 0.025]);
  assert.deepEqual(frame(grab, [0.1, 0, 0.4], [TIP[0], 0, TIP[2] + 0.05]), [0, 0, 0]);
});

test('on slow frames the tip comes to where the hand puts it without passing it', () => {
  // A loaded machine's emulated headset: a frame every 0.4 s; each twist stands until the next frame's, and the tip a
  // frame reads is the one the twist before last left (the joint states' trip). The hand goes 10 cm up at once.
  for (const frameMs of [FRAME_MS, 100, 400, 900]) {
    const grab = new ArmGrab();
    grab.squeeze(0, [0.1, 0, 0.3], TIP, 0);
    const target = TIP[2] + HAND_SCALE * 0.1;
    let tip = TIP[2];
    let seen = tip;
    let highest = tip;
    for (let i = 1; i <= 400; i++) {
      const v = grab.follow([0.1, 0, 0.4], [TIP[0], 0, seen], i * frameMs);
      seen = tip;
      tip += (v[2] * Math.min(frameMs, 500)) / 1000; // the arm's deadman stops a twist 0.5 s old
      highest = Math.max(highest, tip);
    }
    assert.ok(highest < target + 0.001, `at a frame every ${frameMs} ms the tip went ${highest - target} m past`);
    assert.ok(Math.abs(tip - target) < 0.003, `at a frame every ${frameMs} ms the tip stopped ${target - tip} m short`);
  }
  // At 72 frames a second the loop keeps its full gain; at 1 frame a second a quarter of the distance a frame.
  const fast = new ArmGrab();
  fast.squeeze(0, [0.1, 0, 0.3], TIP, 0);
  for (let i = 1; i < 5; i++) frame(fast, [0.1, 0, 0.3], TIP);
  close(frame(fast, [0.1, 0, 0.4], TIP), [0, 0, FOLLOW_GAIN * HAND_SCALE * 0.1]);
  const slow = new ArmGrab();
  slow.squeeze(0, [0.1, 0, 0.3], TIP, 0);
  slow.follow([0.1, 0, 0.3], TIP, 0);
  close(slow.follow([0.1, 0, 0.4], TIP, 1000), [0, 0, FOLLOW_PER_FRAME * HAND_SCALE * 0.1]);
});

test('letting go releases the arm (only the hand that holds it), and then nothing moves it', () => {
  const grab = new ArmGrab();
  grab.squeeze(1, TIP, TIP, 0);
  assert.equal(grab.release(0), false);
  assert.equal(grab.release(1), true);
  assert.deepEqual(frame(grab, [1, 1, 1], TIP), [0, 0, 0]);
  assert.equal(grab.held, null);
});

test('with 1:1 the tip follows the whole motion, and the change takes the arm again where it is', () => {
  const grab = new ArmGrab();
  grab.squeeze(0, [0.1, 0, 0.3], TIP, 0);
  grab.setScale(1, [0.1, 0, 0.35], [TIP[0], 0, TIP[2] + 0.025]);
  // No jump: where the hand and the tip were at the change is the new start.
  assert.deepEqual(frame(grab, [0.1, 0, 0.35], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, 0]);
  close(frame(grab, [0.1, 0, 0.45], [TIP[0], 0, TIP[2] + 0.025]), [0, 0, FOLLOW_GAIN * 0.1]);
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

/** A turn of `angle` rad about the unit `axis`, as a quaternion [x, y, z, w]. @returns {[number, number, number, number]} */
function about(/** @type {number[]} */ axis, /** @type {number} */ angle) {
  const s = Math.sin(angle / 2);
  return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(angle / 2)];
}

test("the hand's turn points the tip, scaled as its motion, and stops once the tip points there", () => {
  const grab = new ArmGrab();
  /** @type {[number, number, number]} */ const forward = [1, 0, 0];
  assert.ok(grab.squeeze(0, [0.3, 0, 0.2], [0.3, 0, 0.2], 0, { hand: about([0, 0, 1], 0), dir: forward }));
  grab.follow([0.3, 0, 0.2], [0.3, 0, 0.2], 14);
  // The hand yaws 90 degrees left: at half scale the tip should point 45 degrees left, so it turns about +z.
  const yawed = grab.turn(about([0, 0, 1], Math.PI / 2), forward);
  assert.ok(Math.abs(yawed[0]) < 1e-9 && Math.abs(yawed[1]) < 1e-9, String(yawed));
  assert.ok(Math.abs(yawed[2] - FOLLOW_GAIN * (Math.PI / 4)) < 1e-9, String(yawed));
  // Once the tip points there, no turn.
  const there = /** @type {[number, number, number]} */ ([Math.SQRT1_2, Math.SQRT1_2, 0]);
  assert.deepEqual(grab.turn(about([0, 0, 1], Math.PI / 2), there), [0, 0, 0]);
  // The hand pitches its fingers down (about +y in the base link, x forward, z up): the tip turns down the same way.
  const pitched = grab.turn(about([0, 1, 0], 0.6), forward);
  assert.ok(pitched[1] > 0 && Math.abs(pitched[0]) < 1e-9 && Math.abs(pitched[2]) < 1e-9, String(pitched));
  // A roll about the tip's own axis points it nowhere new.
  assert.deepEqual(grab.turn(about([1, 0, 0], 1.0), forward), [0, 0, 0]);
});

test('the turn is nothing without a held arm or a known pointing, and 1:1 follows the whole turn', () => {
  const grab = new ArmGrab();
  assert.deepEqual(grab.turn(about([0, 0, 1], 1), [1, 0, 0]), [0, 0, 0]);
  grab.squeeze(0, [0, 0, 0], [0, 0, 0], 0); // its pointing unknown (no skeleton yet)
  assert.deepEqual(grab.turn(about([0, 0, 1], 1), [1, 0, 0]), [0, 0, 0]);
  grab.release(0);
  const start = { hand: about([0, 0, 1], 0), dir: /** @type {[number, number, number]} */ ([1, 0, 0]) };
  grab.squeeze(0, [0, 0, 0], [0, 0, 0], 0, start);
  grab.setScale(1, [0, 0, 0], [0, 0, 0], start);
  grab.follow([0, 0, 0], [0, 0, 0], 14);
  const turned = grab.turn(about([0, 0, 1], 0.5), [1, 0, 0]);
  assert.ok(Math.abs(turned[2] - FOLLOW_GAIN * 0.5) < 1e-9, String(turned));
});
