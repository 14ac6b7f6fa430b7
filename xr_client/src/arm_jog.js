// @ts-check
/**
 * Moving a robot's arm by keys (the desktop) or by the hand (VR), as twists of its tip: which keys move it where, the
 * stream of `<robot>/arm/twist` commands at the teleop rate while it moves and one zero when it stops, and the
 * smoothing of the drawn arm between joint states. No DOM, no WebGL: test/arm_jog.test.js drives it.
 *
 * Keys (desktop, a robot with an arm selected and not held by another operator): I and K move the tip forward and
 * back, J and L left and right, U and O up and down (the arm's base link: x forward, y left, z up, REP 103); [ opens
 * the gripper and ] closes it (M and G are the sound's keys, V is voice's). The relay clamps the speed and refuses
 * what the arm's rules forbid (docs/protocol.md).
 */
import { robotIdentifier } from './protocol.js';

/** The tip's speed while a key is held (m/s): half the demo arm's limit (robots.yaml `arm.limits.linear`, 0.1). */
export const JOG_SPEED = 0.05;
/** Twists are repeated this often while the arm moves (ms): the teleop rate, 20 Hz, within the 0.5 s deadman. */
export const ARM_PERIOD_MS = 50;
/**
 * Key -> [axis, sign] of the tip's motion in the arm's base link.
 * @type {Readonly<Record<string, [number, number]>>}
 */
export const ARM_KEYS = Object.freeze({
  KeyI: [0, 1],
  KeyK: [0, -1],
  KeyJ: [1, 1],
  KeyL: [1, -1],
  KeyU: [2, 1],
  KeyO: [2, -1],
});
/** Key -> the gripper's named state (the SRDF's). @type {Readonly<Record<string, string>>} */
export const GRIPPER_KEYS = Object.freeze({ BracketLeft: 'open', BracketRight: 'close' });

/** @typedef {[number, number, number]} Vec3 */
/** @typedef {{robot: string, linear: Vec3, angular: Vec3}} ArmTwist */
/**
 * @typedef {import('./protocol.js').ArmTwistCommand
 *   | Omit<import('./protocol.js').ArmGripperStateCommand, 'id'>
 *   | Omit<import('./protocol.js').ArmGripperPositionCommand, 'id'>} ArmMessage what CommandSender.arm sends
 */

/** @param {ArmTwist} twist @param {'base' | 'tip'} [frame] @returns {ArmMessage} */
export function armTwistMessage(twist, frame = 'base') {
  const message = {
    identifier: robotIdentifier(twist.robot, 'arm/twist'),
    linear: twist.linear,
    angular: twist.angular,
  };
  return frame === 'base' ? message : { ...message, frame };
}

/**
 * The gripper to a named state of its SRDF (`open`, `close`) or to a position of its joint (m or rad: a trigger's).
 * @param {string} robot @param {string | number} state @returns {ArmMessage}
 */
export function gripperMessage(robot, state) {
  const identifier = robotIdentifier(robot, 'arm/gripper');
  return typeof state === 'number' ? { identifier, position: state } : { identifier, state };
}

/**
 * The tip's velocity the held keys ask for (m/s, base link frame).
 * @param {Iterable<string>} keys held key codes @param {number} [speed] m/s @returns {Vec3}
 */
export function keysToArmTwist(keys, speed = JOG_SPEED) {
  /** @type {Vec3} */
  const v = [0, 0, 0];
  for (const key of keys) {
    const entry = ARM_KEYS[key];
    if (entry) v[entry[0]] += entry[1] * speed;
  }
  return v;
}

/** @param {Vec3} v */
const moving = (v) => v.some((c) => c !== 0);
/** @param {Vec3} a @param {Vec3} b */
const same = (a, b) => a.every((c, i) => c === b[i]);
/** @param {string} robot @returns {ArmTwist} */
const zero = (robot) => ({ robot, linear: [0, 0, 0], angular: [0, 0, 0] });

/** The stream of one operator's arm twists: what to send now, given what is asked for. */
export class ArmJog {
  /** The arm being moved (null: none). @type {string | null} */
  robot = null;
  /** @type {Vec3} */
  linear = [0, 0, 0];
  /** @type {Vec3} */
  angular = [0, 0, 0];
  lastSent = -Infinity;

  /**
   * What to send now for `robot`'s arm (null: no arm may be moved now) asked to move at `linear` and `angular`: a
   * twist when it starts, then the newest every ARM_PERIOD_MS while it moves (a hand's twist changes every frame: at
   * most 20 a second, as teleop), one zero when it stops or the arm changes.
   * @param {string | null} robot @param {Vec3} linear @param {Vec3} angular @param {number} now ms
   * @returns {ArmTwist[]}
   */
  update(robot, linear, angular, now) {
    /** @type {ArmTwist[]} */
    const out = [];
    if (robot !== this.robot) {
      out.push(...this.stop(now));
      this.robot = robot;
    }
    if (robot === null) return out;
    const asked = moving(linear) || moving(angular);
    const was = moving(this.linear) || moving(this.angular);
    const changed = !same(linear, this.linear) || !same(angular, this.angular);
    if (asked && (!was || now - this.lastSent >= ARM_PERIOD_MS)) {
      out.push({ robot, linear: [...linear], angular: [...angular] });
      this.lastSent = now;
    } else if (!asked && changed) {
      out.push(zero(robot));
      this.lastSent = now;
    }
    this.linear = [...linear];
    this.angular = [...angular];
    return out;
  }

  /** Stop moving the arm: one zero if it moved (a hidden page, a lost hand, an E-STOP). @param {number} now */
  stop(now) {
    const robot = this.robot;
    const was = moving(this.linear) || moving(this.angular);
    this.linear = [0, 0, 0];
    this.angular = [0, 0, 0];
    if (robot === null || !was) return [];
    this.lastSent = now;
    return [zero(robot)];
  }
}

/**
 * Move drawn points toward the newest joint state's: exponential smoothing with time constant `tau` (s), so that
 * 20 joint states a second draw as motion, not steps. Writes `current` in place; a new shape is taken at once.
 * @param {number[][]} current @param {number[][]} target @param {number} dt s @param {number} [tau] s
 * @returns {number[][]} current
 */
export function approach(current, target, dt, tau = 0.06) {
  if (current.length !== target.length) {
    current.length = 0;
    for (const p of target) current.push([...p]);
    return current;
  }
  const k = 1 - Math.exp(-Math.max(0, dt) / tau);
  for (let i = 0; i < target.length; i++)
    for (let j = 0; j < 3; j++) current[i][j] += (target[i][j] - current[i][j]) * k;
  return current;
}

/**
 * Where the arm's commands go: the page's connection (connection.js). A twist carries no id and is dropped while
 * disconnected, as cmd_vel is (the relay's deadman stops the arm); the gripper's is acknowledged, and one that cannot
 * be sent is said.
 */
export class ArmSender {
  /**
   * @param {{send(message: Record<string, unknown>, withId?: boolean): string | null}} link
   * @param {(text: string) => void} onNotSent
   */
  constructor(link, onNotSent) {
    this.link = link;
    this.onNotSent = onNotSent;
  }

  /** @param {ArmTwist} twist @param {'base' | 'tip'} [frame] */
  twist(twist, frame = 'base') {
    this.link.send(/** @type {Record<string, unknown>} */ (armTwistMessage(twist, frame)), false);
  }

  /** @param {string} robot @param {string | number} state the SRDF's gripper state (`open`, `close`), or a position */
  gripper(robot, state) {
    const message = gripperMessage(robot, state);
    const id = this.link.send(/** @type {Record<string, unknown>} */ (message));
    if (id === null) this.onNotSent(`not connected: ${message.identifier} not sent`);
    return id;
  }
}
