// @ts-check
/**
 * The fleet as the client knows it: built from `hello`, updated by `<robot>/pose|status|sensor`.
 * No DOM, no WebGL: rendering code only reads it.
 */

/**
 * @typedef {{name: string, colour: string, limits: {linear: number, angular: number},
 *   sensors: {name: string, unit: string}[], cameras: {name: string}[]}} RobotDescription
 * @typedef {{x: number, y: number, yaw: number, stamp: number}} Pose
 * @typedef {{online: boolean, age: number | null, mode: string, goal: {x: number, y: number, yaw: number | null} | null, controller: string | null}} Status
 * @typedef {{name: string, value: number, unit: string, warning: boolean}} Reading
 * @typedef {{description: RobotDescription, pose: Pose | null, status: Status | null, sensors: Map<string, Reading>}} RobotEntry
 */

export class FleetModel {
  constructor() {
    /** @type {Map<string, RobotEntry>} */
    this.robots = new Map();
    /** @type {number[] | null} */
    this.bounds = null;
    this.clientId = '';
  }

  /** @param {any} message */
  apply(message) {
    const identifier = /** @type {string} */ (message.identifier);
    if (identifier === 'hello') {
      this.robots.clear();
      this.bounds = message.bounds;
      this.clientId = message.client_id;
      for (const description of message.robots) {
        const state = message.state[description.name];
        /** @type {RobotEntry} */
        const entry = { description, pose: null, status: state?.status ?? null, sensors: new Map() };
        this.robots.set(description.name, entry);
        if (state?.pose) this.apply(state.pose);
        for (const reading of Object.values(state?.sensors ?? {})) this.apply(reading);
      }
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
}
