// @ts-check
/**
 * Every command the client sends, built in one place from the generated command shapes (protocol.js), with
 * the requests that await an answer. Nothing queues while disconnected: a command that cannot go out returns
 * null and the caller is told through `onNotSent` (the operator must know that a stop did not leave).
 */
import { ERROR_CODES, parseIdentifier, robotIdentifier } from './protocol.js';
import { count } from './wording.js';

/**
 * @typedef {import('./protocol.js').ClientMessage} ClientMessage
 * @typedef {{send(message: Record<string, unknown>, withId?: boolean): string | null}} Link what the sender needs of
 *   the connection: `send` returns the id it gave the message ('' without one), or null when disconnected
 * @typedef {import('./protocol.js').GoalDescription} Goal
 */
/**
 * A command before the connection gives it its id (Omit over each member of the union).
 * @template M
 * @typedef {M extends unknown ? Omit<M, 'id'> : never} WithoutId
 */

/** Wire numbers: millimetres and milliradians are plenty, and the frames stay short. @param {number} v */
export function round(v) {
  return Math.round(v * 1e4) / 1e4 + 0;
}

/**
 * A teleop command's cmd_vel without its stamp `t`: what `twist` sends, and what the socket worker repeats at 20 Hz
 * (stamping each on the page's clock), so that both send the same bytes.
 * @param {import('./teleop.js').TeleopCommand} command
 * @returns {import('./teleop_hold.js').HeldCommand}
 */
export function twistFields(command) {
  return {
    identifier: robotIdentifier(command.robot, 'cmd_vel'),
    linear: round(command.linear),
    angular: round(command.angular),
  };
}

export class CommandSender {
  /** How many commands went out, by kind (tests and the developer console read them). */
  counts = { goals: 0, cmdVel: 0, zeros: 0, estops: 0 };
  /** Snapshots asked for and how they ended; `lastError` is the code of the last refusal. */
  snapshots = { requested: 0, acked: 0, failed: 0, lastError: '' };
  /** Ids of snapshot requests awaiting their ack or error. @type {Set<string>} */
  pendingSnapshots = new Set();
  /**
   * Ids of H.264 stream requests awaiting their ack or error (a relay may refuse video for a camera).
   * @type {Set<string>}
   */
  pendingVideo = new Set();
  /**
   * Called with the relay's `error` when it refuses a stream asked for as H.264 (view/camera_feed.js falls back).
   * @type {(error: import('./protocol.js').ErrorMessage) => void}
   */
  onVideoRefused = () => {};

  /**
   * @param {Link} link
   * @param {(text: string) => void} onNotSent
   * @param {() => number} [clock] milliseconds on a monotonic clock, stamped on every cmd_vel as `t`
   * @param {import('./latency.js').Latency | null} [latency] told when a robot's command leaves (its round trip)
   */
  constructor(link, onNotSent, clock = () => performance.now(), latency = null) {
    this.link = link;
    this.onNotSent = onNotSent;
    this.clock = clock;
    this.latency = latency;
  }

  /**
   * @param {WithoutId<ClientMessage>} message
   * @param {boolean} [withId]
   * @returns {string | null}
   */
  #send(message, withId = true) {
    const id = this.link.send(/** @type {Record<string, unknown>} */ (message), withId);
    if (id === null) this.onNotSent(`not connected: ${message.identifier} not sent`);
    const { robot } = parseIdentifier(message.identifier);
    if (id && robot !== null) this.latency?.sent(id, robot, this.clock());
    return id;
  }

  /** @param {string} robot @param {Goal} goal */
  goal(robot, goal) {
    /** @type {Omit<import('./protocol.js').GoalPoseCommand, 'id'>} */
    const message = { identifier: robotIdentifier(robot, 'goal_pose'), x: round(goal.x), y: round(goal.y) };
    if (goal.yaw !== null) message.yaw = round(goal.yaw);
    const id = this.#send(message);
    if (id) this.counts.goals++;
    return id;
  }

  /**
   * One teleop command; cmd_vel carries no id: the 20 Hz stream is not acknowledged (docs/protocol.md).
   * @param {import('./teleop.js').TeleopCommand} command
   */
  twist(command) {
    /** @type {import('./protocol.js').CmdVelCommand} */
    // `t` lets the relay drop a command that waited (in a frozen relay, a stalled network) past the deadman's timeout.
    const message = { ...twistFields(command), t: Math.round(this.clock()) };
    // Silently dropped while disconnected: the relay's deadman stops the robot on its side.
    if (this.link.send(/** @type {Record<string, unknown>} */ (message), false) === null) return;
    this.counts.cmdVel++;
    if (command.linear === 0 && command.angular === 0) this.counts.zeros++;
  }

  /**
   * @param {string} robot @param {string} camera @param {number} fps 0 stops
   * @param {'jpeg' | 'h264'} [codec] omitted: the relay's default, JPEG
   */
  stream(robot, camera, fps, codec) {
    const id = this.#send(
      codec
        ? { identifier: robotIdentifier(robot, 'stream'), camera, fps, codec }
        : { identifier: robotIdentifier(robot, 'stream'), camera, fps },
    );
    if (id && codec === 'h264' && fps > 0) this.pendingVideo.add(id);
    return id;
  }

  /** @param {string} robot @param {string | null} camera null: the robot's first camera */
  snapshot(robot, camera) {
    const identifier = robotIdentifier(robot, 'snapshot');
    const id = this.#send(camera ? { identifier, camera } : { identifier });
    if (id) {
      this.snapshots.requested++;
      this.pendingSnapshots.add(id);
    }
    return id;
  }

  /** @param {string} robot */
  cancel(robot) {
    return this.#send({ identifier: robotIdentifier(robot, 'cancel') });
  }

  /** The name this operator goes by (the relay tells every client: `operators`). @param {string} name */
  name(name) {
    return this.#send({ identifier: 'name', name });
  }

  /** Take a robot over from the operator who holds it (the relay stops it first). @param {string} robot */
  takeOver(robot) {
    return this.#send({ identifier: robotIdentifier(robot, 'lease'), action: 'acquire', force: true });
  }

  /** Stop every robot, or one. @param {string} [robot] */
  estop(robot) {
    const id = this.#send(robot ? { identifier: 'estop', robot } : { identifier: 'estop' });
    if (id) this.counts.estops++;
    else this.onNotSent('not connected: E-STOP NOT DELIVERED');
    return id;
  }

  /** Lift a latched emergency stop (the robots stay stopped until commanded again). @param {string} [robot] */
  estopReset(robot) {
    return this.#send(
      robot ? { identifier: 'estop', robot, action: 'reset' } : { identifier: 'estop', action: 'reset' },
    );
  }

  /** Start a mission file of the relay's missions/ directory ("demo"). @param {string} file */
  missionStart(file) {
    return this.#send({ identifier: 'mission/start', file });
  }

  /**
   * A mission made in the page: the targets in the order picked, for the fleet or a group of it (``robots``: each
   * target to the nearest free robot of them) or for one robot (inspected in that order).
   * @param {string[]} targets @param {string | null} robot @param {string[] | null} [robots]
   */
  missionTargets(targets, robot, robots = null) {
    if (robot)
      return this.#send({
        identifier: 'mission/start',
        robot,
        steps: targets.map((t) => ({ inspect: t })),
        name: count(targets.length, 'target'),
      });
    const name = count(targets.length, 'target');
    if (robots) return this.#send({ identifier: 'mission/start', targets, robots, name });
    return this.#send({ identifier: 'mission/start', targets, name });
  }

  /** @param {'pause' | 'resume' | 'skip' | 'abort'} action @param {string} mission */
  mission(action, mission) {
    return this.#send({ identifier: /** @type {`mission/${typeof action}`} */ (`mission/${action}`), mission });
  }

  /**
   * Change a finding's status, note or region.
   * @param {string} finding
   * @param {{status?: import('./protocol.js').FindingStatus, note?: string, region?: number[][] | null}} fields
   */
  findingUpdate(finding, fields) {
    return this.#send({ identifier: 'finding/update', finding, ...fields });
  }

  /** A target at a map point. @param {string} target @param {number} x @param {number} y */
  targetAt(target, x, y) {
    return this.#send({ identifier: 'target/add', target, x: round(x), y: round(y) });
  }

  /**
   * A target where a pixel of a capture's image looks (the relay casts the lens ray into the map).
   * @param {string} target @param {string} capture @param {number} u @param {number} v
   */
  targetFromPixel(target, capture, u, v) {
    return this.#send({ identifier: 'target/add', target, capture, u: Math.round(u), v: Math.round(v) });
  }

  /**
   * A target where a pixel of a robot's live camera image looks (pixels of the camera's configured size): the relay
   * captures now, adds the target and a finding to review, and proposes the region around the pixel.
   * @param {string} target @param {string} robot @param {number} u @param {number} v
   */
  targetFromLive(target, robot, u, v) {
    return this.#send({ identifier: 'target/add', target, robot, u: Math.round(u), v: Math.round(v) });
  }

  /**
   * Ask the relay to segment the region around a pixel of a capture's image. @param {string} capture @param {number} u
   * @param {number} v
   */
  region(capture, u, v) {
    return this.#send({ identifier: 'region', capture, u: Math.round(u), v: Math.round(v) });
  }

  /**
   * A page of the findings history, newest first: those made before `before` (a finding's `created`; null: the
   * newest). The answer comes as a `findings` message.
   * @param {number | null} before
   */
  findingsPage(before) {
    return this.#send({ identifier: 'findings/page', ...(before === null ? {} : { before }) });
  }

  /** Acknowledge an alert (the relay records this operator's name). @param {string} alert @param {string} [note] */
  alertAck(alert, note) {
    return this.#send({ identifier: 'alert/ack', alert, ...(note ? { note } : {}) });
  }

  /**
   * Make a schedule (`schedule/add`) or change one (`schedule/update`, the fields changed): schedule_draft.js builds
   * it. The relay answers with `schedules` to every client, then the `ack`.
   * @param {import('./schedule_draft.js').ScheduleCommand} command
   */
  schedule(command) {
    return this.#send(command);
  }

  /** Remove a schedule (its missions stay). @param {string} schedule */
  scheduleRemove(schedule) {
    return this.#send({ identifier: 'schedule/remove', schedule });
  }

  /** An `ack` arrived. @param {import('./protocol.js').RequestId} id */
  acked(id) {
    if (this.pendingSnapshots.delete(String(id))) this.snapshots.acked++;
    this.pendingVideo.delete(String(id));
  }

  /** An `error` arrived. @param {import('./protocol.js').ErrorMessage} error */
  failed(error) {
    if (error.id !== null && this.pendingSnapshots.delete(String(error.id))) {
      this.snapshots.failed++;
      this.snapshots.lastError = error.code;
    }
    // Refused when asked, or later without an id: a camera whose images turned out not to be encodable (its video
    // streams end; the message starts with the camera's identifier).
    if (error.id !== null ? this.pendingVideo.delete(String(error.id)) : error.code === ERROR_CODES.UNSUPPORTED)
      this.onVideoRefused(error);
  }

  /** Whether the last refused snapshot had no image to give. */
  get noImageYet() {
    return this.snapshots.lastError === ERROR_CODES.NO_CAMERA;
  }

  /** A new `hello`: nothing sent before it will be answered. */
  reset() {
    this.pendingSnapshots.clear();
    this.pendingVideo.clear();
  }
}
