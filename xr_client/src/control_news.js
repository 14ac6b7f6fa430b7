// @ts-check
/**
 * What the operator is told about who controls a robot and how its goals end, from the relay's `lease`, `nav` and
 * `error` messages: a robot taken over from this operator (its teleop stops; the cancel of the goal it lost is then
 * not told again), a lease that expired, a goal refused because another operator holds the robot (offered again with
 * a take-over), and each goal's outcome. No DOM, no WebGL: part of MessageRouter, tested through it.
 */
import { ERROR_CODES, parseIdentifier } from './protocol.js';
import { displayName } from './operator_names.js';

/** @typedef {import('./message_router.js').RouterEffect} RouterEffect */

export class ControlNews {
  /**
   * @param {import('./fleet_model.js').FleetModel} fleet
   * @param {import('./goal_pointer.js').GoalTracker} goals
   * @param {Map<string, number[][]>} paths each robot's planned path: a goal's end ends it
   */
  constructor(fleet, goals, paths) {
    this.fleet = fleet;
    this.goals = goals;
    this.paths = paths;
    /** Robots this operator lost to a take-over whose cancelled goal has not been reported yet. @type {Set<string>} */
    this.takenOver = new Set();
  }

  /**
   * Who controls a robot changed. The operator who lost one is told at once (and its teleop stops sending).
   * @param {string} robot @param {import('./protocol.js').LeaseMessage} lease @returns {RouterEffect[]}
   */
  lease(robot, lease) {
    const me = this.fleet.clientId;
    if (lease.previous === me && lease.holder && lease.holder !== me) {
      this.takenOver.add(robot);
      // The lost lease's earcon and pulses come from this event, not from comparing the fleet's state every 100 ms:
      // a page busy drawing (a software-rendered frame takes 100-300 ms) read "mine" and "another's" in one look and
      // never felt the take-over (CI, 2026-11-28).
      return [
        { type: 'stop_teleop' },
        notice(`${robot} was taken over by ${displayName(lease.holder, this.fleet.names, me)}`, 'error'),
        { type: 'cue', kind: 'lease_lost', robot },
      ];
    }
    if (lease.previous === me && lease.reason === 'expired')
      return [notice(`${robot} is free again: you had not commanded it for a while`, 'info')];
    return [];
  }

  /**
   * A command refused because another operator holds the robot: a take-over is offered, with the refused goal if it
   * was one. @param {import('./protocol.js').ErrorMessage} error @returns {RouterEffect[]}
   */
  refused(error) {
    if (error.code !== ERROR_CODES.LEASED || error.id === null) return [];
    // The message names the refused command first (`robot1/goal_pose: robot1 is controlled by ...`).
    const { robot } = parseIdentifier(error.message.split(':')[0]);
    // A refused goal is offered again with the take-over: accepting sends it once the robot is taken.
    const refused = robot === null ? null : this.goals.goals.get(robot);
    const goal = refused?.id === String(error.id) ? refused.goal : null;
    if (robot !== null && this.fleet.robots.has(robot))
      return [{ type: 'offer_takeover', robot, text: error.message, goal }];
    return [];
  }

  /**
   * How a goal went: reached, aborted with the reason, cancelled (nothing for `started`: the path says it). The app
   * tells the operator about the selected robot and the robots it sent. Nav2's feedback and its answer to a cancel
   * go on the robot's label (nav_line.js); a cancel Nav2 did not confirm is also told, as an error: the robot may
   * still be navigating.
   * @param {string} robot @param {import('./protocol.js').NavMessage} nav @param {number} now
   * @returns {RouterEffect[]}
   */
  nav(robot, nav, now) {
    if (!this.fleet.robots.has(robot)) return [];
    this.fleet.setNav(robot, nav, now);
    const mine = this.fleet.robot(robot)?.status?.controller === this.fleet.clientId;
    if (nav.outcome === 'started' && nav.feedback) return [];
    if (nav.confirmed === true) return [];
    if (nav.confirmed === false) return [{ type: 'nav', robot, text: `${robot}: ${nav.message}`, kind: 'error', mine }];
    // The goal this operator lost with the robot: "taken over by Ben" already said it (a second notice, arriving
    // a moment later, would replace the one that says who and why). The next goal to start ends that.
    const lost = this.takenOver.delete(robot);
    if (nav.outcome === 'started') return [];
    this.paths.delete(robot);
    if (nav.outcome === 'cancelled' && lost) return [];
    const at = nav.goal ? ` (${nav.goal.x.toFixed(1)}, ${nav.goal.y.toFixed(1)})` : '';
    const why = nav.message && nav.message !== nav.outcome ? `: ${nav.message}` : '';
    if (nav.outcome === 'reached')
      return [{ type: 'nav', robot, text: `${robot} reached its goal${at}`, kind: 'info', mine }];
    if (nav.outcome === 'failed')
      return [{ type: 'nav', robot, text: `${robot} aborted its goal${at}${why}`, kind: 'error', mine }];
    return [{ type: 'nav', robot, text: `${robot}'s goal${at} cancelled${why}`, kind: 'warning', mine }];
  }
}

/** @param {string} text @param {import('./message_router.js').NoticeKind} kind @returns {RouterEffect} */
function notice(text, kind) {
  return { type: 'notify', text, kind, toast: true };
}
