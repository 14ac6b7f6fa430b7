// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { pinchHandPose } from '../node_modules/iwer/lib/device/configs/hand/pinch.js';
import { pointHandPose } from '../node_modules/iwer/lib/device/configs/hand/point.js';
import { relaxedHandPose } from '../node_modules/iwer/lib/device/configs/hand/relaxed.js';
import { fistHandPose } from './fixtures/hand_poses.js';
import {
  DWELL_MS,
  DWELL_TOLERANCE_M,
  Dwell,
  FIST_ENGAGE,
  FIST_HOLD_MS,
  FIST_RELEASE,
  FistHold,
  JOYSTICK_DEAD_M,
  JOYSTICK_RANGE_M,
  PalmUp,
  PinchDetector,
  PinchJoystick,
  distance,
  fingerReach,
  palmNormal,
  position,
} from '../src/gestures.js';

/** Thumb tip and index tip of a recorded pose (IWER's, captured from a Quest's hand tracking). @param {any} pose */
function tips(pose) {
  const j = pose.jointTransforms;
  return { thumb: position(j['thumb-tip'].offsetMatrix), index: position(j['index-finger-tip'].offsetMatrix) };
}

/** @param {import('../src/gestures.js').Vec3} a @param {import('../src/gestures.js').Vec3} b @param {number} t */
const lerp = (a, b, t) => /** @type {import('../src/gestures.js').Vec3} */ (a.map((v, i) => v + (b[i] - v) * t));

test('the recorded poses: a pinch is a pinch, pointing and a relaxed hand are not', () => {
  for (const [pose, pinched] of [
    [pinchHandPose, true],
    [pointHandPose, false],
    [relaxedHandPose, false],
  ]) {
    const { thumb, index } = tips(pose);
    const detector = new PinchDetector();
    assert.equal(detector.update(distance(thumb, index)).pinched, pinched);
  }
});

test('closing and opening the hand, with tracking jitter: one pinch and one release, no chatter', () => {
  const open = tips(relaxedHandPose);
  const closed = tips(pinchHandPose);
  const detector = new PinchDetector();
  const changes = [];
  let seed = 7;
  const jitter = () => ((seed = (seed * 16807) % 2147483647) / 2147483647 - 0.5) * 0.006; // +-3 mm
  const steps = [...Array(40).keys()].map((k) => k / 39);
  for (const t of [...steps, ...steps.reverse()]) {
    const thumb = lerp(open.thumb, closed.thumb, t);
    const index = lerp(open.index, closed.index, t);
    const { changed, pinched } = detector.update(distance(thumb, index) + jitter());
    if (changed) changes.push(pinched);
  }
  assert.deepEqual(changes, [true, false]);
  detector.update(0.001);
  detector.reset();
  assert.equal(detector.pinched, false, 'a lost hand is not pinching');
});

test('palm up: the recorded relaxed hand faces down; turned over, up; half-way keeps what it was', () => {
  const wrist = relaxedHandPose.jointTransforms.wrist.offsetMatrix;
  const normal = palmNormal(wrist);
  const palm = new PalmUp();
  assert.equal(palm.update(normal), false, `palm down as recorded (${normal})`);
  // Turned over: 180 degrees about the forearm (z) flips x and y.
  assert.equal(palm.update([-normal[0], -normal[1], normal[2]]), true);
  // Sideways (normal horizontal, ~60 degrees from up): still up (hysteresis), then down past it.
  assert.equal(palm.update([0.85, 0.5, 0]), true);
  assert.equal(palm.update([0.95, 0.3, 0]), false);
  assert.equal(palm.update([0.85, 0.5, 0]), false, 'and not up again until well up');
});

test('dwell: fills over DWELL_MS, fires once, restarts when the gaze moves on, tolerates small wander', () => {
  const dwell = new Dwell();
  const on = (/** @type {number} */ x, id = 'hemisphere') => ({
    id,
    point: /** @type {import('../src/gestures.js').Vec3} */ ([x, 1.5, -2]),
  });
  assert.deepEqual(dwell.update(on(0), 0), { fill: 0, fire: false, id: 'hemisphere' });
  assert.equal(dwell.update(on(DWELL_TOLERANCE_M * 0.8), DWELL_MS / 2).fill, 0.5, 'a small wander keeps the dwell');
  const fired = dwell.update(on(0), DWELL_MS);
  assert.deepEqual(fired, { fill: 1, fire: true, id: 'hemisphere' });
  assert.equal(dwell.update(on(0), DWELL_MS * 3).fire, false, 'once per rest');
  assert.equal(dwell.update(on(0.3), DWELL_MS * 3 + 10).fill, 0, 'moved on: restarts');
  assert.equal(dwell.update(on(0.3, 'menu:estop'), DWELL_MS * 3 + 20).id, 'menu:estop');
  assert.equal(dwell.update(null, DWELL_MS * 4).fill, 0, 'on nothing: empty');
});

test('pinch-drag joystick: dead zone, full speed at the range, forward follows the head, release is zero at once', () => {
  const limits = { linear: 0.8, angular: 1.2 };
  const stick = new PinchJoystick();
  assert.deepEqual(stick.update([0, 1, 0], 0, limits), { linear: 0, angular: 0 }, 'no pinch: nothing');
  stick.start([0, 1, 0]);
  assert.deepEqual(stick.update([JOYSTICK_DEAD_M * 0.9, 1, -JOYSTICK_DEAD_M * 0.9], 0, limits), {
    linear: 0,
    angular: 0,
  });
  assert.deepEqual(
    stick.update([0, 1, -JOYSTICK_RANGE_M], 0, limits),
    { linear: 0.8, angular: 0 },
    'forward (-z): full',
  );
  assert.deepEqual(stick.update([0, 1, JOYSTICK_RANGE_M * 2], 0, limits), { linear: -0.8, angular: 0 }, 'clamped back');
  assert.deepEqual(
    stick.update([JOYSTICK_RANGE_M, 1, 0], 0, limits),
    { linear: 0, angular: -1.2 },
    'right turns clockwise',
  );
  // The head turned 90 degrees left (yaw +pi/2 faces -x): moving the hand along -x is forward.
  const turned = stick.update([-JOYSTICK_RANGE_M, 1, 0], Math.PI / 2, limits);
  assert.ok(Math.abs(turned.linear - 0.8) < 1e-3 && Math.abs(turned.angular) < 1e-3, JSON.stringify(turned));
  assert.deepEqual(stick.release(), { linear: 0, angular: 0 });
  assert.deepEqual(stick.update([0, 1, -JOYSTICK_RANGE_M], 0, limits), { linear: 0, angular: 0 }, 'released: nothing');
});

/** A recorded pose's joints by name (positions), for fingerReach. @param {any} pose */
const joints = (pose) => (/** @type {string} */ name) =>
  pose.jointTransforms[name] ? position(pose.jointTransforms[name].offsetMatrix) : null;

/** Joint positions of a pose part-way from one to another (a hand closing). @param {any} a @param {any} b @param {number} t */
const between = (a, b, t) => (/** @type {string} */ name) =>
  lerp(position(a.jointTransforms[name].offsetMatrix), position(b.jointTransforms[name].offsetMatrix), t);

test('a fist: the fist made from the recorded point pose is one; the recorded relaxed, pinch and point poses are not', () => {
  const fist = /** @type {number[]} */ (fingerReach(joints(fistHandPose)));
  assert.ok(Math.max(...fist) < FIST_ENGAGE, `every finger in: ${fist.map((r) => r.toFixed(2))}`);
  for (const pose of [relaxedHandPose, pinchHandPose, pointHandPose]) {
    const reach = /** @type {number[]} */ (fingerReach(joints(pose)));
    assert.ok(Math.max(...reach) > FIST_RELEASE, `a finger out: ${reach.map((r) => r.toFixed(2))}`);
  }
  // The pose IWER mirrors for the right hand reads the same (distances, not sides).
  const mirrored = (/** @type {string} */ name) => {
    const p = joints(fistHandPose)(name);
    return p && /** @type {import('../src/gestures.js').Vec3} */ ([-p[0], p[1], p[2]]);
  };
  assert.deepEqual(fingerReach(mirrored), fist);
  assert.equal(
    fingerReach(() => null),
    null,
    'an untracked hand has no reach',
  );
});

test('fist and hold: the E-STOP fires once after FIST_HOLD_MS closed, not before, and again only after opening', () => {
  const hold = new FistHold();
  const fist = fingerReach(joints(fistHandPose));
  const open = fingerReach(joints(relaxedHandPose));
  assert.deepEqual(hold.update(open, 0), { closed: false, fill: 0, fire: false });
  assert.equal(hold.update(fist, 100).closed, true);
  const half = hold.update(fist, 100 + FIST_HOLD_MS / 2);
  assert.ok(!half.fire && Math.abs(half.fill - 0.5) < 1e-9, JSON.stringify(half));
  assert.deepEqual(hold.update(fist, 100 + FIST_HOLD_MS), { closed: true, fill: 1, fire: true });
  assert.equal(hold.update(fist, 100 + 3 * FIST_HOLD_MS).fire, false, 'held on: once');
  hold.update(open, 4000);
  hold.update(fist, 4100);
  assert.equal(hold.update(fist, 4100 + FIST_HOLD_MS).fire, true, 'opened and closed again: again');
  // Opened before the time: nothing, and the next close starts over.
  const short = new FistHold();
  short.update(fist, 0);
  short.update(open, FIST_HOLD_MS * 0.9);
  short.update(fist, FIST_HOLD_MS);
  assert.equal(short.update(fist, FIST_HOLD_MS * 1.9).fire, false);
  // Tracking lost mid-hold: nothing.
  const lost = new FistHold();
  lost.update(fist, 0);
  lost.update(null, 100);
  assert.equal(lost.update(fist, FIST_HOLD_MS + 50).fire, false);
});

test('closing the hand and opening it, with jitter: one fist and one opening, no chatter', () => {
  const hold = new FistHold();
  const changes = [];
  let seed = 11;
  const jitter = () => ((seed = (seed * 16807) % 2147483647) / 2147483647 - 0.5) * 0.04; // +-2 % of a hand length
  const steps = [...Array(40).keys()].map((k) => k / 39);
  let closed = false;
  let t = 0;
  for (const s of [...steps, ...steps.reverse()]) {
    const reach = /** @type {number[]} */ (fingerReach(between(relaxedHandPose, fistHandPose, s))).map(
      (r) => r + jitter(),
    );
    const now = hold.update(reach, (t += 10)).closed;
    if (now !== closed) changes.push((closed = now));
  }
  assert.deepEqual(changes, [true, false]);
});
