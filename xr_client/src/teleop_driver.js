// @ts-check
/**
 * Teleop's effects: the page's TeleopLoop (the single source of behaviour: shaping, sources, releases, stops) and
 * where its commands go. With a socket worker (connection.js), the page sends the first command of a drive and every
 * zero itself, and the worker's clock repeats the held command at 20 Hz however slow the frames are (teleop_hold.js);
 * without one, the page's loop sends every command, as before.
 *
 * Order matters: the worker hears that nothing is held before the page sends a zero, so that no repeat of the old
 * command can follow the zero. The page confirms what is held at least every CONFIRM_MS while it runs (its 10 ms
 * timer and every frame call `tick`); a page that stops confirming has its robot stopped by the worker (HOLD_MS),
 * and is told here, and the stick must come back to the centre before it drives again, as after any stop.
 */
import { twistFields } from './command_sender.js';
import { shapeStick } from './teleop.js';

/** How often the page confirms an unchanged held command to the worker (ms): a tenth of the hold bound. */
export const CONFIRM_MS = 100;

/**
 * @typedef {import('./teleop_hold.js').HeldCommand} HeldCommand
 * @typedef {{hold(command: HeldCommand | null, epoch: number): boolean, link: EventTarget | null}} HoldLink the
 *   connection: `hold` returns whether a worker's clock repeats the command
 */

export class TeleopDriver {
  /** Stops the worker made because this page fell silent. */
  expiries = 0;
  /** @type {HeldCommand | null} what the worker was last told to repeat */
  posted = null;
  postedAt = -Infinity;
  /** Whether the worker's clock repeats `posted` (else the page's loop sends it). */
  workerClock = false;
  /** The worker's epoch as this page last heard it (teleop_hold.js). */
  epoch = 0;

  /**
   * @param {import('./teleop.js').TeleopLoop} loop
   * @param {import('./command_sender.js').CommandSender} sender
   * @param {HoldLink} link
   * @param {(text: string) => void} notify tells the operator (the worker stopped the robot)
   */
  constructor(loop, sender, link, notify) {
    this.loop = loop;
    this.sender = sender;
    this.link = link;
    this.notify = notify;
    link.link?.addEventListener('sent', this.#onSent);
    link.link?.addEventListener('expired', this.#onExpired);
  }

  /**
   * A stick (or keys as one) from an input source, for this robot, shaped by its limits.
   * @param {string} source @param {number} x @param {number} y
   * @param {{name: string, limits: import('./protocol.js').Limits}} robot @param {number} now
   */
  stick(source, x, y, robot, now) {
    this.setRobot(robot.name, robot.limits, now);
    const { linear, angular } = shapeStick(x, y, robot.limits);
    this.#send(this.loop.input(source, linear, angular, now), now);
  }

  /** @param {string | null} robot @param {import('./protocol.js').Limits} limits @param {number} now */
  setRobot(robot, limits, now) {
    this.#send(this.loop.setRobot(robot, limits, now), now);
  }

  /**
   * Stop driving (TeleopLoop.stop). `silent`: the zero is not sent (an E-STOP goes instead, or the robot is no longer
   * this operator's), but the worker stops repeating all the same.
   * @param {number} now @param {boolean} [silent]
   */
  stop(now, silent = false) {
    const zeros = this.loop.stop(now);
    this.#send(silent ? [] : zeros, now);
  }

  /**
   * The page's timer and every frame: the loop's cadence when the page sends, and the worker's confirmation.
   * @param {number} now
   */
  tick(now) {
    const due = this.loop.tick(now);
    // While the worker repeats the command the page's cadence only keeps the loop's state; else the page sends.
    this.#send(this.workerClock ? [] : due, now);
  }

  /** @param {import('./teleop.js').TeleopCommand[]} commands @param {number} now */
  #send(commands, now) {
    this.#sync(now);
    for (const command of commands) this.sender.twist(command);
    // The first command of a drive has just gone out: the worker's repeats follow from it.
    if (commands.length > 0) this.#sync(now);
  }

  /** Tell the worker what to repeat when it changed, and confirm it now and then. @param {number} now */
  #sync(now) {
    const loop = this.loop;
    const active = loop.driving && loop.robot !== null && (loop.command.linear !== 0 || loop.command.angular !== 0);
    const held = active ? twistFields({ robot: /** @type {string} */ (loop.robot), ...loop.command }) : null;
    const same =
      held === this.posted ||
      (held !== null &&
        this.posted !== null &&
        held.identifier === this.posted.identifier &&
        held.linear === this.posted.linear &&
        held.angular === this.posted.angular);
    if (same && (held === null || now - this.postedAt < CONFIRM_MS)) return;
    this.workerClock = this.link.hold(held, this.epoch);
    this.posted = held;
    this.postedAt = now;
  }

  /** A cmd_vel the worker's clock sent: counted like the page's own. @param {Event} event */
  #onSent = (event) => {
    const counts = this.sender.counts;
    counts.cmdVel++;
    if (/** @type {CustomEvent} */ (event).detail.zero) counts.zeros++;
  };

  /** The worker stopped the robot: this page had not confirmed its command in time. @param {Event} event */
  #onExpired = (event) => {
    const { silent, epoch } = /** @type {CustomEvent<import('./teleop_hold.js').Expiry>} */ (event).detail;
    this.epoch = epoch;
    this.expiries++;
    // The worker sent the zero; the loop stops as for any stop (the stick must come back to the centre).
    this.stop(performance.now(), true);
    this.notify(
      `Teleop stopped: this page did not answer for ${(silent / 1000).toFixed(1)} s. Centre the stick to drive again.`,
    );
  };

  dispose() {
    this.link.link?.removeEventListener('sent', this.#onSent);
    this.link.link?.removeEventListener('expired', this.#onExpired);
  }
}
