// @ts-check
/**
 * The fleet as the client knows it: built from `hello`, updated by `<robot>/pose|status|sensor` and by
 * `scene` (the same shape as `hello.scene`). No DOM, no WebGL: rendering code only reads it. The message
 * shapes are the relay's, generated into protocol.js; this module keeps no copy of them.
 */
import { parseMapToScene } from './frames.js';
import { parseIdentifier } from './protocol.js';

/**
 * @typedef {import('./protocol.js').RobotDescription} RobotDescription
 * @typedef {import('./protocol.js').CameraDescription} CameraDescription
 * @typedef {import('./protocol.js').SensorDescription} SensorDescription
 * @typedef {import('./protocol.js').StatusMessage} Status
 * @typedef {import('./protocol.js').SensorMessage} Reading
 * @typedef {import('./protocol.js').ServerMessage} ServerMessage
 * @typedef {{x: number, y: number, yaw: number, stamp: number}} Pose the part of a PoseMessage the client keeps
 * @typedef {{message: import('./protocol.js').NavMessage, at: number}} NavNews the latest `<robot>/nav`, and when it
 *   came (page ms)
 * @typedef {{description: RobotDescription, pose: Pose | null, status: Status | null,
 *   sensors: Map<string, Reading>, nav: NavNews | null}} RobotEntry
 * @typedef {{url: string | null, mapToScene: import('./frames.js').MapToScene}} Scene
 */

export class FleetModel {
  constructor() {
    /** @type {Map<string, RobotEntry>} */
    this.robots = new Map();
    /** @type {number[] | null} */
    this.bounds = null;
    /** Where an operator sees the most robots from (the relay's hello.vantage; map frame), if known.
     * @type {import('./protocol.js').VantageDescription | null} */
    this.vantage = null;
    /**
     * The scene file's named areas (hello.rooms), written on the twin's floor.
     * @type {import('./protocol.js').RoomDescription[]}
     */
    this.rooms = [];
    this.clientId = '';
    /** Connected clients by id -> the name each gave (the relay's `operators`). @type {Map<string, string>} */
    this.names = new Map();
    /** @type {import('./protocol.js').Role} */
    this.role = 'operator';
    /** @type {Scene} */
    this.scene = { url: null, mapToScene: parseMapToScene(null) };
    /** Increments when the fleet or the scene is replaced (hello, scene), not on every pose. */
    this.generation = 0;
  }

  /**
   * Apply one message from the relay; true when it changed the model.
   * @param {ServerMessage} message
   */
  apply(message) {
    const { robot, kind } = parseIdentifier(message.identifier);
    if (robot === null) {
      if (kind === 'hello') this.#hello(/** @type {import('./protocol.js').HelloMessage} */ (message));
      else if (kind === 'scene') this.#setScene(/** @type {import('./protocol.js').SceneMessage} */ (message));
      else return false;
      this.generation++;
      return true;
    }
    const entry = this.robots.get(robot);
    if (!entry) return false;
    if (kind === 'pose') {
      const pose = /** @type {import('./protocol.js').PoseMessage} */ (message);
      entry.pose = { x: pose.x, y: pose.y, yaw: pose.yaw, stamp: pose.stamp };
    } else if (kind === 'status') entry.status = /** @type {Status} */ (message);
    else if (kind === 'sensor') {
      const reading = /** @type {Reading} */ (message);
      entry.sensors.set(reading.name, reading);
    } else return false;
    return true;
  }

  /** @param {import('./protocol.js').HelloMessage} hello */
  #hello(hello) {
    this.robots.clear();
    this.bounds = hello.bounds ?? null;
    this.vantage = hello.vantage ?? null;
    this.rooms = Array.isArray(hello.rooms) ? hello.rooms : [];
    this.clientId = hello.client_id;
    this.role = hello.role; // what the page offers follows it (roles.js): an inspector drives nothing
    this.#setScene(hello.scene);
    for (const description of hello.robots) {
      const state = hello.state?.[description.name];
      /** @type {RobotEntry} */
      const entry = { description, pose: null, status: state?.status ?? null, sensors: new Map(), nav: null };
      this.robots.set(description.name, entry);
      if (state?.pose) this.apply(state.pose);
      for (const reading of Object.values(state?.sensors ?? {})) this.apply(reading);
    }
  }

  /** @param {import('./protocol.js').SceneDescription | null | undefined} scene */
  #setScene(scene) {
    this.scene = { url: scene?.url ?? null, mapToScene: parseMapToScene(scene?.map_to_scene) };
  }

  /**
   * The robot's latest `<robot>/nav` (its label shows Nav2's feedback and the outcome: nav_line.js). A confirmation
   * of a goal given up earlier does not replace the feedback of the goal the robot follows now.
   * @param {string} robot @param {import('./protocol.js').NavMessage} message @param {number} now page ms
   */
  setNav(robot, message, now) {
    const entry = this.robots.get(robot);
    if (!entry) return;
    const following = entry.nav?.message.outcome === 'started' && entry.status?.mode === 'navigating';
    if (message.confirmed !== null && message.confirmed !== undefined && following) return;
    entry.nav = { message, at: now };
  }

  /** @param {string | null} name */
  robot(name) {
    return name === null ? null : (this.robots.get(name) ?? null);
  }

  /**
   * The robot's camera for Robot POV (its first not on an arm: that one looks where the gripper does, not where the
   * robot goes), or null. @param {string | null} name
   */
  camera(name) {
    const cameras = this.robot(name)?.description.cameras ?? [];
    return cameras.find((c) => !c.on_arm) ?? null;
  }
}
