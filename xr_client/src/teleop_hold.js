// @ts-check
/**
 * The teleop sending clock of the socket worker (socket_worker.js), without I/O: it repeats the page's current
 * command at 20 Hz, off the page's main thread, and stops by itself when the page stops confirming it.
 *
 * Why: under a software renderer a frame holds the page's main thread for 100-500 ms (SwiftShader in CI), and up to
 * ~1 s on a loaded machine; a clock on that thread sent cmd_vel at the frame rate (8 in 3 s), and the relay's 0.5 s
 * deadman stopped the robot between commands. The worker's timers run whatever the frames do.
 *
 * The page stays the single source of behaviour (TeleopLoop: shaping, sources, releases, stops): it sends the first
 * command of a drive and every zero itself, and tells the worker what to repeat (`hold`) whenever that changes and
 * at least once per frame. The worker only repeats, on the cadence of TeleopLoop (`nextDue`), and:
 * - a page that has not confirmed its command for `HOLD_MS` is not to be trusted with a moving robot (frozen, crashed,
 *   a modal dialog, a debugger): the worker sends one zero, stops, and says so (`expired`);
 * - an expiry starts a new epoch: a confirmation the page posted before it heard of the expiry (it was frozen, the
 *   messages crossed) is stale and ignored, so the robot does not lurch off again before the page has stopped its
 *   loop (after which the stick must come back to the centre, as after any stop);
 * - a `null` hold (release, stop, switch, disconnect) is always accepted, whatever its epoch: stopping is never stale.
 * Times are milliseconds on the worker's monotonic clock; tested in test/teleop_hold.test.js.
 */
import { TELEOP_PERIOD_MS, nextDue } from './teleop.js';

/**
 * How long the worker repeats a command the page has not confirmed (ms). Long enough for the slowest frames measured
 * under SwiftShader: in VR (every frame drawn) on the 2-core CI machine shared with other jobs (load average 7.5),
 * the page's main thread answered every 466 ms (median) and at worst after 1048 ms; on the desktop page a load spike
 * held it 1108 ms once (2026-11-23, gaps between 10 ms timer ticks over 15 s). A slow but living page keeps driving.
 * Short enough that a frozen page stops its robot soon: 1.5 s after its last confirmation, at most 0.9 m at the demo
 * fleet's fastest 0.6 m/s; a page that is gone altogether is stopped sooner, by the relay's 0.5 s deadman.
 */
export const HOLD_MS = 1500;

/**
 * @typedef {{identifier: string, linear: number, angular: number}} HeldCommand a cmd_vel as CommandSender builds it,
 * without its stamp `t`
 */
/**
 * @typedef {{identifier: string, silent: number, epoch: number}} Expiry the robot's cmd_vel identifier, how long the
 * page was silent (ms), the new epoch
 */

export class TeleopHold {
  /** @param {{period?: number, bound?: number}} [options] */
  constructor(options = {}) {
    this.period = options.period ?? TELEOP_PERIOD_MS;
    this.bound = options.bound ?? HOLD_MS;
    /** Bumped by each expiry; a hold for an older epoch is stale. */
    this.epoch = 0;
    /** @type {HeldCommand | null} what is being repeated */
    this.held = null;
    this.confirmedAt = 0;
    this.due = 0;
    /** Commands this clock produced (repeats and zeros). */
    this.sent = 0;
  }

  /**
   * The page's current command (null: nothing to repeat), confirmed now.
   * @param {HeldCommand | null} command @param {number} epoch the newest epoch the page knows @param {number} now
   */
  hold(command, epoch, now) {
    if (command === null) {
      this.held = null;
      return;
    }
    if (epoch !== this.epoch) return; // posted before the page heard of an expiry
    if (this.held === null || this.held.identifier !== command.identifier) {
      // A new drive: the page sent its first command itself, just now; the repeats follow one period later.
      this.due = now + this.period;
    }
    this.held = { identifier: command.identifier, linear: command.linear, angular: command.angular };
    this.confirmedAt = now;
  }

  /** The socket is gone (or a new one is opening): nothing is repeated onto another. */
  drop() {
    this.held = null;
  }

  /** When `tick` has something to do next (ms), or null while nothing is held. */
  wakeAt() {
    return this.held === null ? null : Math.min(this.due, this.confirmedAt + this.bound);
  }

  /**
   * What to send now: the held command when it is due, or, past the bound, one zero and the expiry.
   * @param {number} now
   * @returns {{send: HeldCommand[], expired: Expiry | null}}
   */
  tick(now) {
    const held = this.held;
    if (held === null) return { send: [], expired: null };
    if (now - this.confirmedAt >= this.bound) {
      this.held = null;
      this.epoch++;
      this.sent++;
      const zero = { identifier: held.identifier, linear: 0, angular: 0 };
      return {
        send: [zero],
        expired: { identifier: held.identifier, silent: now - this.confirmedAt, epoch: this.epoch },
      };
    }
    if (now < this.due) return { send: [], expired: null };
    this.due = nextDue(this.due, now, this.period);
    this.sent++;
    return { send: [held], expired: null };
  }
}

/**
 * The text frame of a held command stamped `t` (ms on the page's clock): the bytes CommandSender.twist sends.
 * @param {HeldCommand} command @param {number} t
 */
export function stampedText(command, t) {
  return JSON.stringify({
    identifier: command.identifier,
    linear: command.linear,
    angular: command.angular,
    t: Math.round(t),
  });
}
