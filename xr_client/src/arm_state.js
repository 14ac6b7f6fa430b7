// @ts-check
/**
 * What the relay says of the fleet's arms and what they work on: each arm's newest joints (`<robot>/joints`), the
 * facility's valve wheel (`valve`), and the arms' refused motions (`arm_refused`: a joint limit, the workspace's
 * edge, the arm reaching into its base), whose reason is shown near the gripper and pulsed on the holding hand. The
 * message router feeds it; the views read it. No DOM, no WebGL: test/arm_state.test.js drives it.
 */
import { parseIdentifier } from './protocol.js';

/** A refusal's reason stays near the gripper this long after the last one (ms): long enough to read a line. */
export const REFUSAL_SHOWN_MS = 2500;
/** Refused twists come at the hand's 20 a second: the holding hand is pulsed at most this often (ms). */
export const REFUSAL_PULSE_MS = 400;

/**
 * @typedef {import('./protocol.js').JointsMessage} JointsMessage
 * @typedef {import('./protocol.js').ValveMessage} ValveMessage
 * @typedef {{robot: string, reason: string, at: number, pulsed: number}} Refusal
 */

export class ArmState {
  /** Each arm's newest joints, drawn by view/arm_view.js. @type {Map<string, JointsMessage>} */
  joints = new Map();
  /** The facility's valve wheel (sim backend), drawn by view/valve_view.js. @type {ValveMessage | null} */
  valve = null;
  /** Each arm's latest refused motion. @type {Map<string, Refusal>} */
  refusals = new Map();

  /** A new `hello`: the relay sends the valve again right after it, if it has one. @param {boolean} rebuild */
  hello(rebuild) {
    if (rebuild) this.joints.clear();
    this.valve = null;
    this.refusals.clear();
  }

  /**
   * An arm command's refusal (`arm_refused`): the effect that pulses the arm's holding hand, at most every
   * REFUSAL_PULSE_MS for one arm (none for any other error).
   * @param {import('./protocol.js').ErrorMessage} error @param {number} now ms
   * @returns {{type: 'arm_refused', robot: string}[]}
   */
  refused(error, now) {
    if (error.code !== 'arm_refused') return [];
    const [identifier, ...rest] = error.message.split(': ');
    const { robot, kind } = parseIdentifier(identifier);
    if (robot === null || !kind.startsWith('arm/')) return [];
    const reason = rest
      .join(': ')
      .replace(/^refused: /, '')
      .replace(/; the arm stopped where it is$/, '');
    const last = this.refusals.get(robot);
    const pulse = !last || now - last.pulsed >= REFUSAL_PULSE_MS;
    this.refusals.set(robot, { robot, reason, at: now, pulsed: pulse ? now : (last?.pulsed ?? now) });
    return pulse ? [{ type: 'arm_refused', robot }] : [];
  }

  /** The reason to show near `robot`'s gripper now, or null. @param {string} robot @param {number} now ms */
  refusal(robot, now) {
    const last = this.refusals.get(robot);
    return last && now - last.at < REFUSAL_SHOWN_MS ? last.reason : null;
  }
}
