// @ts-check
/**
 * Hand and gaze gestures as pure recognisers (no three.js, no WebXR; time passed in), for the hand input of
 * issue #17: a pinch with hysteresis (so that a trembling pinch is not a stream of clicks), the palm turned up (the
 * wrist buttons appear), a head-gaze dwell with its fill, the pinch-drag joystick that drives a robot with the
 * release as its deadman, and (#31) a fist held closed: E-STOP with no controller and nothing to aim at. Tested
 * against IWER's recorded hand poses (Meta's captured joints: pinch, point, relaxed; a fist made from `point`) in
 * test/gestures.test.js.
 *
 * Joint frames follow the WebXR Hand Input spec: a joint's -Z runs along its bone toward the finger tip and its +Y
 * points out of the back of the hand, so the palm faces the joint's -Y.
 */

/** Thumb tip to index tip (m) under which a pinch starts, and over which it ends (between: as it was). */
export const PINCH_ENGAGE_M = 0.02;
export const PINCH_RELEASE_M = 0.035;
/** The palm counts as up when its normal is within ~50 deg of the world's up, and down again past ~70 deg. */
export const PALM_UP_ENGAGE = 0.64;
export const PALM_UP_RELEASE = 0.34;
/** Head-gaze dwell: how long, and how far the gaze may wander (m on what it rests on) without restarting. */
export const DWELL_MS = 1500;
export const DWELL_TOLERANCE_M = 0.05;
/** Pinch-drag joystick: the hand's travel (m) for full speed, and the dead zone around where the pinch began. */
export const JOYSTICK_RANGE_M = 0.15;
export const JOYSTICK_DEAD_M = 0.02;

/**
 * A fist: every finger's tip (index to little) nearer the palm's centre than FIST_ENGAGE hand lengths (wrist to the
 * middle knuckle: ~9.6 cm in IWER's poses), open again when one is farther than FIST_RELEASE. Measured on IWER's
 * recorded poses: a relaxed hand 1.22-1.48 (its little finger nearest), a pinch's index 1.09, the point pose's
 * stretched index 1.41 (its three curled fingers 0.37-0.55), a fist 0.37-0.62. Held FIST_HOLD_MS, it stops the fleet:
 * long enough that closing the hand in passing does not, short enough for an emergency (a ring fills meanwhile).
 */
export const FIST_ENGAGE = 0.75;
export const FIST_RELEASE = 0.95;
export const FIST_HOLD_MS = 800;
export const FINGERS = Object.freeze(['index', 'middle', 'ring', 'pinky']);

/** @typedef {[number, number, number]} Vec3 */

/** @param {Vec3} a @param {Vec3} b */
export function distance(a, b) {
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/** The translation of a column-major 4x4 matrix (WebXR's, three.js's). @param {ArrayLike<number>} m @returns {Vec3} */
export function position(m) {
  return [m[12], m[13], m[14]];
}

/**
 * The palm's normal in the matrix's frame: the wrist joint's -Y axis. @param {ArrayLike<number>} wrist @returns {Vec3}
 */
export function palmNormal(wrist) {
  return [-wrist[4], -wrist[5], -wrist[6]];
}

/** A pinch with hysteresis. */
export class PinchDetector {
  pinched = false;

  /** @param {number} gap thumb tip to index tip (m) @returns {{pinched: boolean, changed: boolean}} */
  update(gap) {
    const before = this.pinched;
    if (!this.pinched && gap < PINCH_ENGAGE_M) this.pinched = true;
    else if (this.pinched && gap > PINCH_RELEASE_M) this.pinched = false;
    return { pinched: this.pinched, changed: this.pinched !== before };
  }

  /** The hand was lost (tracking, a switch to controllers): no pinch. */
  reset() {
    this.pinched = false;
  }
}

/** The palm turned up (toward the sky), with hysteresis. */
export class PalmUp {
  up = false;

  /** @param {Vec3} normal the palm's normal in world axes (y up) @returns {boolean} */
  update(normal) {
    const length = Math.hypot(...normal) || 1;
    const cos = normal[1] / length;
    if (!this.up && cos > PALM_UP_ENGAGE) this.up = true;
    else if (this.up && cos < PALM_UP_RELEASE) this.up = false;
    return this.up;
  }
}

/** A head-gaze dwell: resting on one thing long enough fires once; looking away restarts it. */
export class Dwell {
  /** @type {{id: string, point: Vec3, since: number, fired: boolean} | null} */
  current = null;

  /**
   * Where the gaze rests now (null: on nothing). @param {{id: string, point: Vec3} | null} on @param {number} now ms
   * @returns {{fill: number, fire: boolean, id: string | null}} the fill of the ring (0..1), and whether it fired now
   */
  update(on, now) {
    const c = this.current;
    if (!on) {
      this.current = null;
      return { fill: 0, fire: false, id: null };
    }
    if (!c || c.id !== on.id || distance(c.point, on.point) > DWELL_TOLERANCE_M) {
      this.current = { id: on.id, point: on.point, since: now, fired: false };
      return { fill: 0, fire: false, id: on.id };
    }
    const fill = Math.min(1, (now - c.since) / DWELL_MS);
    if (fill >= 1 && !c.fired) {
      c.fired = true; // once per rest: look away (or move on) to dwell again
      return { fill: 1, fire: true, id: c.id };
    }
    return { fill: c.fired ? 0 : fill, fire: false, id: c.id };
  }
}

/**
 * The pinch-drag joystick: where the pinch began is the stick's centre; the hand's travel forward/back and
 * left/right (in the head's frame, so that forward is where the operator faces) maps to linear and angular speed
 * within the robot's limits. Releasing the pinch is the deadman: zero at once.
 */
export class PinchJoystick {
  /** @type {Vec3 | null} */
  origin = null;

  /** The pinch began here. @param {Vec3} hand */
  start(hand) {
    this.origin = hand;
  }

  /**
   * The hand's travel as a stick (each axis -1..1 after the dead zone, y -1 forward, as a gamepad's): what the
   * teleop loop takes, shaping it to the robot's limits itself. @param {Vec3} hand @param {number} headYaw the head's
   * yaw (rad, about +y; 0 faces -z) @returns {{x: number, y: number}}
   */
  axes(hand, headYaw) {
    if (!this.origin) return { x: 0, y: 0 };
    const dx = hand[0] - this.origin[0];
    const dz = hand[2] - this.origin[2];
    // Into the head's frame: forward is -z after undoing the yaw.
    const c = Math.cos(headYaw);
    const s = Math.sin(headYaw);
    const right = c * dx - s * dz;
    const forward = -(s * dx + c * dz);
    const shape = (/** @type {number} */ v) => {
      const a = Math.abs(v);
      if (a < JOYSTICK_DEAD_M) return 0;
      return Math.sign(v) * Math.min(1, (a - JOYSTICK_DEAD_M) / (JOYSTICK_RANGE_M - JOYSTICK_DEAD_M));
    };
    return { x: shape(right) + 0, y: -shape(forward) + 0 }; // + 0: no -0
  }

  /**
   * The command for the hand's place now, scaled to the robot's limits. @param {Vec3} hand @param {number} headYaw
   * @param {{linear: number, angular: number}} limits @returns {{linear: number, angular: number}}
   */
  update(hand, headYaw, limits) {
    const { x, y } = this.axes(hand, headYaw);
    const round = (/** @type {number} */ v) => Math.round(v * 1000) / 1000 + 0;
    return { linear: round(-y * limits.linear), angular: round(-x * limits.angular) };
  }

  /** The pinch ended (or the hand was lost): zero, at once. @returns {{linear: number, angular: number}} */
  release() {
    this.origin = null;
    return { linear: 0, angular: 0 };
  }
}

/**
 * How far each finger's tip (index, middle, ring, little) is from the palm's centre (half-way from the wrist to the
 * middle knuckle), in hand lengths (wrist to the middle knuckle), so that a small hand and a large one read alike;
 * null when a joint is not tracked. @param {(name: string) => Vec3 | null} joint a joint's position by its WebXR name
 * @returns {number[] | null}
 */
export function fingerReach(joint) {
  const wrist = joint('wrist');
  const knuckle = joint('middle-finger-phalanx-proximal');
  if (!wrist || !knuckle) return null;
  const length = distance(wrist, knuckle);
  if (length < 1e-3) return null;
  const palm = /** @type {Vec3} */ (wrist.map((v, i) => (v + knuckle[i]) / 2));
  const reach = [];
  for (const finger of FINGERS) {
    const tip = joint(`${finger}-finger-tip`);
    if (!tip) return null;
    reach.push(distance(tip, palm) / length);
  }
  return reach;
}

/**
 * A fist held closed: closed when every finger is in (FIST_ENGAGE), open when one is out (FIST_RELEASE); held
 * FIST_HOLD_MS it fires once, and fires again only after the hand opened. A hand that is lost opens it.
 */
export class FistHold {
  closed = false;
  since = 0;
  fired = false;

  /**
   * @param {number[] | null} reach fingerReach() of the hand now (null: not tracked) @param {number} now ms
   * @returns {{closed: boolean, fill: number, fire: boolean}} fill: how far through the hold (0..1; 0 once fired)
   */
  update(reach, now) {
    if (!reach) {
      this.reset();
      return { closed: false, fill: 0, fire: false };
    }
    const farthest = Math.max(...reach);
    if (!this.closed && farthest < FIST_ENGAGE) {
      this.closed = true;
      this.since = now;
      this.fired = false;
    } else if (this.closed && farthest > FIST_RELEASE) this.reset();
    if (!this.closed) return { closed: false, fill: 0, fire: false };
    const fill = Math.min(1, (now - this.since) / FIST_HOLD_MS);
    if (fill >= 1 && !this.fired) {
      this.fired = true;
      return { closed: true, fill: 1, fire: true };
    }
    return { closed: true, fill: this.fired ? 0 : fill, fire: false };
  }

  reset() {
    this.closed = false;
    this.fired = false;
  }
}
