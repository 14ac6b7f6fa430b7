// @ts-check
/**
 * The fleet as the client knows it: built from `hello`, updated by `<robot>/pose|status|sensor` and by a
 * future `scene` message (the same shape as `hello.scene`). No DOM, no WebGL: rendering code only reads it.
 */
import { parseMapToScene } from './frames.js';

/**
 * @typedef {{model: string, fov: number, K?: number[], D?: number[]}} LensDescription
 * @typedef {{name: string, identifier: string, lens: LensDescription, width: number, height: number}} CameraDescription
 * @typedef {{name: string, unit: string, warn_above?: number | null, warn_below?: number | null}} SensorDescription
 * @typedef {{name: string, colour: string, model?: string, limits: {linear: number, angular: number},
 *   sensors: SensorDescription[], cameras: CameraDescription[]}} RobotDescription
 * @typedef {{x: number, y: number, yaw: number, stamp: number}} Pose
 * @typedef {{online: boolean, age: number | null, mode: string, goal: {x: number, y: number, yaw: number | null} | null, controller: string | null}} Status
 * @typedef {{name: string, value: number, unit: string, warning: boolean}} Reading
 * @typedef {{description: RobotDescription, pose: Pose | null, status: Status | null, sensors: Map<string, Reading>}} RobotEntry
 * @typedef {{url: string | null, mapToScene: import('./frames.js').MapToScene}} Scene
 */

export class FleetModel {
  constructor() {
    /** @type {Map<string, RobotEntry>} */
    this.robots = new Map();
    /** @type {number[] | null} */
    this.bounds = null;
    this.clientId = '';
    /** @type {'operator' | 'viewer'} */
    this.role = 'operator';
    /** @type {Scene} */
    this.scene = { url: null, mapToScene: parseMapToScene(null) };
    /** Increments when the fleet or the scene is replaced (hello, scene), not on every pose. */
    this.generation = 0;
  }

  /**
   * Apply one message from the relay; true when it changed the model.
   * @param {any} message
   */
  apply(message) {
    const identifier = /** @type {string} */ (message.identifier);
    if (identifier === 'hello') {
      this.robots.clear();
      this.bounds = message.bounds ?? null;
      this.clientId = message.client_id;
      this.role = message.role === 'viewer' ? 'viewer' : 'operator';
      this.#setScene(message.scene);
      for (const description of message.robots) {
        const state = message.state?.[description.name];
        /** @type {RobotEntry} */
        const entry = { description, pose: null, status: state?.status ?? null, sensors: new Map() };
        this.robots.set(description.name, entry);
        if (state?.pose) this.apply(state.pose);
        for (const reading of Object.values(state?.sensors ?? {})) this.apply(reading);
      }
      this.generation++;
      return true;
    }
    if (identifier === 'scene') {
      this.#setScene(message);
      this.generation++;
      return true;
    }
    const slash = identifier.indexOf('/');
    if (slash < 0) return false;
    const entry = this.robots.get(identifier.slice(0, slash));
    if (!entry) return false;
    const kind = identifier.slice(slash + 1);
    if (kind === 'pose') entry.pose = { x: message.x, y: message.y, yaw: message.yaw, stamp: message.stamp };
    else if (kind === 'status') entry.status = message;
    else if (kind === 'sensor') entry.sensors.set(message.name, message);
    else return false;
    return true;
  }

  /** @param {any} scene */
  #setScene(scene) {
    this.scene = { url: scene?.url ?? null, mapToScene: parseMapToScene(scene?.map_to_scene) };
  }

  /** @param {string | null} name */
  robot(name) {
    return name === null ? null : (this.robots.get(name) ?? null);
  }

  /** The robot's first camera, or null. @param {string | null} name */
  camera(name) {
    return this.robot(name)?.description.cameras?.[0] ?? null;
  }
}
