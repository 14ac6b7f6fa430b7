// @ts-check
/**
 * Taking a robot's arm by the hand in VR: a squeeze (the grip button) near the arm's gripper takes it; while held,
 * the gripper follows the hand's motion from where the squeeze began, scaled down for precision; letting go (or the
 * hand leaving tracking) releases it, and the arm stops. Positions are in the arm's base link (metres; x forward,
 * y left, z up): the view turns the hand's pose into that frame through the robot's body, so the robot's pose, its
 * heading and the twin's scale are already in them. No DOM, no WebGL: test/arm_grab.test.js drives it.
 *
 * The hand's turn is followed too, as the tip's pointing (the gripper's axis: the last link of the joints' skeleton):
 * the hand's rotation since the squeeze, scaled as its motion is, turns the direction the tip pointed then, and the
 * twist's angular part turns the tip toward it at the same gain (the relay fits orientation in what the position
 * leaves free: a four-joint arm follows the hand's pitch and yaw as far as its wrist can). Roll about the gripper's
 * own axis is not followed (the demo arm has no wrist roll).
 *
 * The twist is a position loop, not the hand's velocity: it drives the tip toward where the hand puts it, so a
 * refused or clamped motion never accumulates an offset, and the tip stops where the hand stops. A twist stands until
 * the next frame sends another, and the tip it is computed from is at least a frame old: on slow frames the loop's
 * gain comes down (FOLLOW_PER_FRAME), or a gain fit for 72 frames a second overshoots where the hand stopped (a CI
 * run's emulated headset, at a few frames a second, put the gripper 38 % past it). The hand's motion is
 * scaled by half unless the operator asks for 1:1 (the menu's **Hand 1:1**). While the hand holds the arm, its
 * trigger is the gripper (GripperTrigger): its travel from rest to fully pulled is the gripper's from open to closed,
 * from the moment the hand takes the arm (a trigger at rest opens it).
 */

/** How near the gripper (m) a squeeze must begin to take the arm: about a hand's width. */
export const GRAB_RADIUS = 0.15;
/** The tip moves this much per metre of the hand's motion: half, for precision (1 with the menu's Hand 1:1). */
export const HAND_SCALE = 0.5;
/** Of the distance between where the tip is and where the hand puts it, this much a second (1/s). */
export const FOLLOW_GAIN = 3;
/**
 * At most this much of the distance left is covered in one frame's interval (the twist stands that long, and the tip
 * it was computed from is a frame late): a quarter keeps the loop from overshooting with one frame of delay (its
 * poles meet at 0.5), where a gain of FOLLOW_GAIN at a frame of 0.33 s or more overshoots. A headset's 72 frames a
 * second (14 ms) keep FOLLOW_GAIN.
 */
export const FOLLOW_PER_FRAME = 0.25;
/** The frame interval the gain is fitted to forgets a slow frame by this much a frame (a stall is not forever). */
const INTERVAL_DECAY = 0.9;
/** Closer than this (m) the tip is where the hand puts it: no twist (the joint states' rounding is 0.1 mm). */
export const DEAD_BAND = 0.002;
/** Closer than this (rad, about a degree) the tip points where the hand turns it: no turn. */
export const TURN_DEAD_BAND = 0.02;
/** The trigger moves the gripper at most this often (ms): 10 commands a second, each acknowledged by the relay. */
export const GRIP_PERIOD_MS = 100;
/** A change of the trigger smaller than this (of its travel) is not sent, except to reach either end. */
export const GRIP_STEP = 0.05;
/**
 * A trigger held still sends its position again this often (ms): a command the relay dropped (stale after a stall,
 * refused while another hand held the robot) is not left standing while the trigger says otherwise.
 */
export const GRIP_REFRESH_MS = 1000;

/** @typedef {[number, number, number]} Vec3 */
/** @typedef {[number, number, number, number]} Quat x, y, z, w */
/** @typedef {{hand: Quat, dir: Vec3}} Pointing the hand's orientation and the tip's direction, in the base link */

export class ArmGrab {
  /** The hand holding the arm (its input slot), where it and the tip were when it took it, and how they pointed. */
  /** @type {{slot: number, hand: Vec3, tip: Vec3, pointing: Pointing | null} | null} */
  held = null;
  /** The loop's gain at the last follow (1/s): the turn uses the frame's. */
  gain = FOLLOW_GAIN;
  /** The tip's motion per metre of the hand's. */
  scale = HAND_SCALE;
  /** The frames' interval (s): the longest lately, forgotten slowly (INTERVAL_DECAY). */
  interval = 0;
  /** When follow was last asked (ms). */
  lastFollow = NaN;

  /**
   * Scale the hand's motion by `scale` from now: a held arm is taken again where the hand and the tip are, so the
   * change never makes the tip jump. @param {number} scale @param {Vec3 | null} hand @param {Vec3 | null} tip
   * @param {Pointing | null} [pointing]
   */
  setScale(scale, hand, tip, pointing = null) {
    if (scale === this.scale) return;
    this.scale = scale;
    if (this.held && hand && tip) this.held = { slot: this.held.slot, hand: [...hand], tip: [...tip], pointing };
  }

  /**
   * A squeeze began: the hand of `slot` takes the arm when it is within GRAB_RADIUS of the tip (and no other hand
   * holds it). @param {number} slot @param {Vec3} hand @param {Vec3} tip @param {number} now ms (the frame's)
   * @param {Pointing | null} [pointing] how the hand and the tip point (null: the turn is not followed)
   * @returns {boolean} whether it took it
   */
  squeeze(slot, hand, tip, now, pointing = null) {
    if (this.held !== null || distance(hand, tip) > GRAB_RADIUS) return false;
    this.held = { slot, hand: [...hand], tip: [...tip], pointing };
    this.lastFollow = now; // the first twist's gain is fitted to the frame it follows
    this.interval = 0;
    return true;
  }

  /**
   * The tip's velocity (m/s) toward where the held hand puts it now, asked once a frame; zeros when nothing holds it.
   * @param {Vec3} hand @param {Vec3} tip @param {number} now ms @returns {Vec3}
   */
  follow(hand, tip, now) {
    const dt = (now - this.lastFollow) / 1000;
    this.lastFollow = now;
    if (this.held === null) return [0, 0, 0];
    if (dt > 0) this.interval = Math.max(dt, this.interval * INTERVAL_DECAY);
    const { hand: hand0, tip: tip0 } = this.held;
    const error = /** @type {Vec3} */ ([0, 1, 2].map((i) => tip0[i] + this.scale * (hand[i] - hand0[i]) - tip[i]));
    if (distance(error, [0, 0, 0]) < DEAD_BAND) return [0, 0, 0];
    const gain = this.interval > 0 ? Math.min(FOLLOW_GAIN, FOLLOW_PER_FRAME / this.interval) : FOLLOW_GAIN;
    this.gain = gain;
    return /** @type {Vec3} */ (error.map((e) => gain * e));
  }

  /**
   * The tip's angular velocity (rad/s, base link) toward where the held hand's turn points it, asked after `follow`
   * in the same frame (its gain); zeros when nothing holds it or its pointing was not known.
   * @param {Quat | null} hand the hand's orientation now @param {Vec3 | null} dir the tip's direction now
   * @returns {Vec3}
   */
  turn(hand, dir) {
    const start = this.held?.pointing;
    if (!start || !hand || !dir) return [0, 0, 0];
    const [axis, angle] = axisAngle(multiply(hand, conjugate(start.hand)));
    const wanted = rotate(fromAxisAngle(axis, this.scale * angle), start.dir);
    const cross = /** @type {Vec3} */ ([
      dir[1] * wanted[2] - dir[2] * wanted[1],
      dir[2] * wanted[0] - dir[0] * wanted[2],
      dir[0] * wanted[1] - dir[1] * wanted[0],
    ]);
    const sine = Math.hypot(...cross);
    const off = Math.atan2(sine, dir[0] * wanted[0] + dir[1] * wanted[1] + dir[2] * wanted[2]);
    if (off < TURN_DEAD_BAND || sine === 0) return [0, 0, 0];
    return /** @type {Vec3} */ (cross.map((c) => (this.gain * off * c) / sine));
  }

  /** The hand of `slot` let go (or left tracking): whether it held the arm. @param {number} slot */
  release(slot) {
    if (this.held?.slot !== slot) return false;
    this.held = null;
    return true;
  }
}

/** The held arm's gripper by the trigger: what to send as it is pulled and let go. */
export class GripperTrigger {
  /** The trigger's travel last sent (NaN: nothing yet: the hand that takes the arm sets its gripper at once). */
  sent = NaN;
  lastSent = -Infinity;

  /**
   * The gripper's position to send now for the trigger at `value` (0 at rest .. 1 pulled), or null: a change of
   * GRIP_STEP or more (or to either end), at most every GRIP_PERIOD_MS; what the rate holds back goes at the next;
   * the same position again after GRIP_REFRESH_MS.
   * @param {number} value @param {number[]} range the gripper's [open, close] (`<robot>/joints`' `gripper`)
   * @param {number} now ms @returns {number | null}
   */
  update(value, range, now) {
    const v = Math.min(1, Math.max(0, value));
    if (range.length !== 2 || now - this.lastSent < GRIP_PERIOD_MS) return null;
    const refresh = now - this.lastSent >= GRIP_REFRESH_MS;
    if (v === this.sent && !refresh) return null;
    if (Math.abs(v - this.sent) < GRIP_STEP && v !== 0 && v !== 1 && !refresh) return null;
    this.sent = v;
    this.lastSent = now;
    return range[0] + v * (range[1] - range[0]);
  }

  /** The hand let go of the arm: the next hold sets the gripper afresh. */
  reset() {
    this.sent = NaN;
    this.lastSent = -Infinity;
  }
}

/** @param {number[]} a @param {number[]} b */
function distance(a, b) {
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/** The rotation `b`, then `a` (the Hamilton product a * b). @param {Quat} a @param {Quat} b @returns {Quat} */
function multiply(a, b) {
  const [ax, ay, az, aw] = a;
  const [bx, by, bz, bw] = b;
  return [
    aw * bx + ax * bw + ay * bz - az * by,
    aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw,
    aw * bw - ax * bx - ay * by - az * bz,
  ];
}

/** @param {Quat} q @returns {Quat} */
function conjugate(q) {
  return [-q[0], -q[1], -q[2], q[3]];
}

/** The rotation's unit axis and its angle in [0, pi] (rad). @param {Quat} q @returns {[Vec3, number]} */
function axisAngle(q) {
  const w = q[3] < 0 ? -q[3] : q[3]; // the shorter way round
  const sign = q[3] < 0 ? -1 : 1;
  const s = Math.hypot(q[0], q[1], q[2]);
  if (s < 1e-12) return [[1, 0, 0], 0];
  return [[(sign * q[0]) / s, (sign * q[1]) / s, (sign * q[2]) / s], 2 * Math.atan2(s, w)];
}

/** @param {Vec3} axis unit @param {number} angle rad @returns {Quat} */
function fromAxisAngle(axis, angle) {
  const s = Math.sin(angle / 2);
  return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(angle / 2)];
}

/** The vector `v` turned by `q`. @param {Quat} q @param {Vec3} v @returns {Vec3} */
function rotate(q, v) {
  const r = multiply(multiply(q, [v[0], v[1], v[2], 0]), conjugate(q));
  return [r[0], r[1], r[2]];
}
