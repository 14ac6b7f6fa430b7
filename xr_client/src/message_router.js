// @ts-check
/**
 * Every message from the relay, routed to the models it updates, returning the effects the app and its views
 * carry out (the way MenuState returns its effects). What the operator is told about who controls a robot and how
 * its goals end (`lease`, `nav`, a refused command) is control_news.js's. No DOM, no WebGL:
 * test/message_router.test.js drives it with the relay's message shapes.
 */
import { parseIdentifier } from './protocol.js';
import { PoseSmoother } from './pose_smoother.js';
import { InspectionModel } from './inspection_model.js';
import { Freshness, LINK_STALE_MS } from './freshness.js';
import { ControlNews } from './control_news.js';
import { VoxelMapModel } from './voxel_map.js';
import { ArmState } from './arm_state.js';
import { AvatarModel } from './avatar_model.js';
import { StudyModel } from './study_model.js';

/**
 * @typedef {import('./protocol.js').ServerMessage} ServerMessage
 * @typedef {import('./protocol.js').HelloMessage | import('./protocol.js').SceneMessage
 *   | import('./protocol.js').AckMessage | import('./protocol.js').ErrorMessage | import('./protocol.js').EstopMessage
 *   | import('./protocol.js').PlaybackMessage | import('./protocol.js').BackendMessage
 *   | import('./protocol.js').PongMessage | import('./protocol.js').TargetsMessage
 *   | import('./protocol.js').TargetsChangedMessage | import('./protocol.js').MissionMessage
 *   | import('./protocol.js').FindingMessage | import('./protocol.js').RegionMessage
 *   | import('./protocol.js').FindingsMessage | import('./protocol.js').OperatorsMessage
 *   | import('./protocol.js').AlertMessage | import('./protocol.js').SchedulesMessage
 *   | import('./protocol.js').VoxelMapMessage | import('./protocol.js').StudyMessage
 *   | import('./protocol.js').AvatarMessage | import('./protocol.js').ValveMessage} GlobalMessage the messages
 *   whose identifier is a literal, so that a switch on it narrows the type
 * @typedef {'info' | 'error' | 'warning'} NoticeKind
 * @typedef {{type: 'fleet', rebuild: boolean}
 *   | {type: 'scene'}
 *   | {type: 'notify', text: string, kind: NoticeKind, toast: boolean}
 *   | {type: 'stop_teleop'}
 *   | {type: 'cue', kind: import('./cue_rules.js').CueKind, robot: string | null}
 *   | {type: 'link'}
 *   | {type: 'model', robot: string}
 *   | {type: 'scan', robot: string, scan: import('./protocol.js').ScanMessage}
 *   | {type: 'goal_state', robot: string, active: boolean}
 *   | {type: 'estop_state', latched: string[]}
 *   | {type: 'sensor_warning', robot: string}
 *   | {type: 'offer_takeover', robot: string, text: string, goal: import('./protocol.js').GoalDescription | null}
 *   | {type: 'names'}
 *   | {type: 'inspection'}
 *   | {type: 'voxels'}
 *   | {type: 'study'}
 *   | {type: 'condition', muted: boolean | null, ask: string}
 *   | {type: 'arm_refused', robot: string}
 *   | {type: 'nav', robot: string, text: string, kind: NoticeKind, mine: boolean}} RouterEffect
 * @typedef {{fleet: import('./fleet_model.js').FleetModel, goals: import('./goal_pointer.js').GoalTracker,
 *   history: import('./sensor_history.js').SensorHistory, commands: import('./command_sender.js').CommandSender,
 *   inspection?: InspectionModel, latency?: import('./latency.js').Latency, voxels?: VoxelMapModel,
 *   study?: StudyModel}} RouterModels
 */

export class MessageRouter {
  /** The replayed recording (a bag, a session), if any. @type {import('./protocol.js').PlaybackMessage | null} */
  playback = null;
  /** Pose smoothing per robot, fed here and sampled by the frame loop. @type {Map<string, PoseSmoother>} */
  smoothers = new Map();
  /** When each robot's pose and each sensor (`robot/sensor`) last came, against their usual rates. */
  freshness = new Freshness();
  /** When the relay last said anything (page ms), and how many hellos it sent (a second one is a reconnect). */
  lastMessage = -Infinity;
  hellos = 0;
  /** Each robot's planned path (map frame), while it has one. @type {Map<string, number[][]>} */
  paths = new Map();
  /** Who latched each robot's estop (`estop`; a reset forgets it). @type {Map<string, string | null>} */
  estopBy = new Map();
  /** The arms' joints, the valve they turn and their refused motions (arm_state.js). */
  arms = new ArmState();
  avatars = new AvatarModel(); // a replayed session's operators (avatar_model.js), drawn by view/avatar_view.js
  /** The fleet description of the last `hello`, to rebuild robot views only when it changed. */
  #robotsKey = '';

  /** @param {RouterModels} models */
  constructor(models) {
    this.fleet = models.fleet;
    this.goals = models.goals;
    this.history = models.history;
    this.commands = models.commands;
    this.inspection = models.inspection ?? new InspectionModel();
    /** How late poses and answers come (latency.js), when the page shows it. */
    this.latency = models.latency ?? null;
    /** Who controls a robot, and how its goals end, told to the operator (control_news.js). */
    this.control = new ControlNews(this.fleet, this.goals, this.paths);
    /** The live 3D map's blocks (voxel_map.js): `voxel_map` here, its binary frames from the app. */
    this.voxels = models.voxels ?? new VoxelMapModel();
    /** The study the relay runs, if any (study_model.js): the study panel draws it. */
    this.study = models.study ?? new StudyModel();
  }

  /**
   * @param {ServerMessage} message
   * @param {number} now page time, ms
   * @returns {RouterEffect[]}
   */
  route(message, now) {
    this.lastMessage = now;
    const { robot, kind } = parseIdentifier(message.identifier);
    if (robot === null) return this.#global(/** @type {GlobalMessage} */ (message), now);
    switch (kind) {
      case 'lease':
        return this.control.lease(robot, /** @type {import('./protocol.js').LeaseMessage} */ (message));
      case 'model':
        return this.#model(robot, /** @type {import('./protocol.js').ModelMessage} */ (message));
      case 'scan':
        return this.fleet.robots.has(robot)
          ? [{ type: 'scan', robot, scan: /** @type {import('./protocol.js').ScanMessage} */ (message) }]
          : [];
      case 'path': {
        const points = /** @type {import('./protocol.js').PathMessage} */ (message).points;
        if (!this.fleet.robots.has(robot)) return [];
        if (points.length > 1) this.paths.set(robot, points);
        else this.paths.delete(robot);
        return [];
      }
      case 'nav':
        return this.control.nav(robot, /** @type {import('./protocol.js').NavMessage} */ (message), now);
      case 'joints':
        if (this.fleet.robots.has(robot))
          this.arms.joints.set(robot, /** @type {import('./protocol.js').JointsMessage} */ (message));
        return [];
    }
    if (!this.fleet.apply(message)) return [];
    if (kind === 'pose') {
      const pose = /** @type {import('./protocol.js').PoseMessage} */ (message);
      this.smoother(robot).push(pose.x, pose.y, pose.yaw, now);
      this.freshness.seen(robot, now);
      this.latency?.pose(robot, pose.stamp, now);
      if (this.playback) this.avatars.at(pose.stamp); // a replay's time: operators far from it are gone
    } else if (kind === 'status') {
      const status = /** @type {import('./protocol.js').StatusMessage} */ (message);
      this.goals.status(robot, status.goal, now);
      return [
        { type: 'goal_state', robot, active: status.goal !== null && status.goal !== undefined },
        { type: 'estop_state', latched: this.latched() },
      ];
    } else if (kind === 'sensor') {
      const reading = /** @type {import('./protocol.js').SensorMessage} */ (message);
      this.freshness.seen(`${robot}/${reading.name}`, now);
      if (this.history.add(robot, reading.name, reading.value, reading.warning, now))
        return [notice(crossed(this.fleet, robot, reading), 'warning'), { type: 'sensor_warning', robot }];
    }
    return [];
  }

  /** @param {GlobalMessage} message @param {number} now @returns {RouterEffect[]} */
  #global(message, now) {
    switch (message.identifier) {
      case 'hello':
        return this.#hello(message, now);
      case 'scene':
        this.fleet.apply(message);
        return [{ type: 'scene' }];
      case 'ack':
        this.goals.acked(String(message.id));
        this.commands.acked(message.id);
        this.latency?.answered(String(message.id), now);
        return this.inspection.settle(String(message.id), true) ? [{ type: 'inspection' }] : [];
      case 'error':
        return this.#error(message, now);
      case 'estop': {
        const by = message.by ? ` (by ${message.by === this.fleet.clientId ? 'you' : message.by})` : '';
        // A relay from before the latch sends no `latched`: its estop was a stop.
        // The message is the latch's news: the banner shows (or goes) now, not with the next status.
        for (const r of message.robots) {
          if (message.latched === true) this.estopBy.set(r, message.by);
          else this.estopBy.delete(r);
          const entry = this.fleet.robots.get(r);
          if (entry?.status && message.latched !== undefined)
            entry.status = { ...entry.status, estopped: message.latched };
        }
        const state = /** @type {RouterEffect} */ ({ type: 'estop_state', latched: this.latched() });
        if (message.latched === false)
          return [notice(`E-STOP reset: ${message.robots.join(', ')}${by}`, 'info'), state];
        return [{ type: 'stop_teleop' }, notice(`EMERGENCY STOP: ${message.robots.join(', ')}${by}`, 'error'), state];
      }
      case 'playback':
        this.playback = message;
        return [{ type: 'link' }];
      case 'backend':
        return [
          notice(
            message.ok ? `${message.name} backend working again` : `${message.name} backend failed: ${message.message}`,
            message.ok ? 'info' : 'error',
          ),
        ];
      case 'operators':
        this.fleet.names = new Map(Object.entries(message.names));
        return [{ type: 'names' }];
      case 'targets':
      case 'targets_changed':
      case 'mission':
      case 'finding':
      case 'findings':
      case 'alert':
      case 'schedules':
      case 'region': {
        const told = this.inspection.apply(message).map((n) => notice(n.text, n.kind));
        return [{ type: 'inspection' }, ...told];
      }
      case 'voxel_map':
        this.voxels.begin(message);
        return [{ type: 'voxels' }];
      case 'study':
        return this.study.apply(message, now);
      case 'avatar':
        return this.avatars.apply(message);
      case 'valve':
        this.arms.valve = message;
        return [];
      default:
        return []; // pong: the connection measures it
    }
  }

  /** @param {import('./protocol.js').HelloMessage} hello @param {number} now @returns {RouterEffect[]} */
  #hello(hello, now) {
    this.fleet.apply(hello);
    this.playback = hello.playback ?? null;
    this.goals.reset();
    this.paths.clear();
    this.freshness.reset();
    this.latency?.reset();
    this.hellos++;
    this.commands.reset();
    this.avatars.clear();
    this.inspection.reset(); // the relay sends the targets, missions and findings again right after hello
    // Robot views are rebuilt only when the fleet description changed (a reconnect to the same relay
    // keeps them, and with them their loaded models).
    const key = JSON.stringify(hello.robots);
    const rebuild = key !== this.#robotsKey;
    this.#robotsKey = key;
    if (rebuild) this.smoothers.clear();
    this.arms.hello(rebuild);
    for (const [name, entry] of this.fleet.robots) {
      if (entry.pose) this.smoother(name).push(entry.pose.x, entry.pose.y, entry.pose.yaw, now);
      if (entry.status) this.goals.status(name, entry.status.goal, now);
    }
    /** @type {RouterEffect[]} */
    const effects = [
      { type: 'fleet', rebuild },
      { type: 'estop_state', latched: this.latched() },
    ];
    // A second hello is a reconnect: robots may have moved meanwhile; say so rather than let them jump unexplained.
    if (this.hellos > 1) effects.push(notice('Reconnected: showing the fleet as the relay sees it now', 'info'));
    return effects;
  }

  /**
   * Whether the relay has gone quiet (no message, not even a pong, for LINK_STALE_MS) or the link is down: then
   * everything shown is old. @param {boolean} connected @param {number} now
   */
  linkStale(connected, now) {
    return !connected || now - this.lastMessage > LINK_STALE_MS;
  }

  /** The robots whose emergency stop is latched (their status says so until an operator resets it). */
  latched() {
    return [...this.fleet.robots.values()].filter((r) => r.status?.estopped === true).map((r) => r.description.name);
  }

  /** @param {import('./protocol.js').ErrorMessage} error @param {number} now @returns {RouterEffect[]} */
  #error(error, now) {
    /** @type {RouterEffect[]} */
    const effects = [...this.control.refused(error), ...this.arms.refused(error, now)];
    this.commands.failed(error);
    if (error.id !== null) this.latency?.answered(String(error.id), now);
    if (error.id !== null && this.inspection.settle(String(error.id), false, error.message))
      effects.push({ type: 'inspection' });
    const shownAtMarker = this.goals.failed(
      error.id === null ? null : String(error.id),
      error.code,
      error.message,
      now,
    );
    effects.push({ type: 'notify', text: `${error.code}: ${error.message}`, kind: 'error', toast: !shownAtMarker });
    return effects;
  }

  /**
   * The relay built this robot's model from its robot_description. @param {string} robot
   * @param {import('./protocol.js').ModelMessage} model
   */
  #model(robot, model) {
    const entry = this.fleet.robots.get(robot);
    if (!entry || entry.description.model === model.url) return [];
    entry.description = { ...entry.description, model: model.url };
    return [/** @type {RouterEffect} */ ({ type: 'model', robot })];
  }

  /** @param {string} name */
  smoother(name) {
    let s = this.smoothers.get(name);
    if (!s) this.smoothers.set(name, (s = new PoseSmoother()));
    return s;
  }
}

/**
 * A sensor's warning as an event, with the value that crossed: the panel goes on showing the live reading, and the
 * two agree. @param {import('./fleet_model.js').FleetModel} fleet @param {string} robot
 * @param {import('./protocol.js').SensorMessage} reading @returns {string}
 */
function crossed(fleet, robot, reading) {
  const sensor = fleet.robot(robot)?.description.sensors?.find((s) => s.name === reading.name);
  const limit =
    sensor?.warn_above != null && reading.value > sensor.warn_above
      ? `over ${sensor.warn_above}`
      : sensor?.warn_below != null
        ? `under ${sensor.warn_below}`
        : 'past its limit';
  const then = `${reading.value.toFixed(1)} ${reading.unit} then`;
  return `WARNING ${robot}: ${reading.name} crossed ${limit} ${reading.unit} (${then})`;
}

/** @param {string} text @param {NoticeKind} kind @returns {RouterEffect} */
function notice(text, kind) {
  return { type: 'notify', text, kind, toast: true };
}
