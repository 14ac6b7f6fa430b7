// @ts-check
/**
 * Teleoperation without DOM or WebGL: stick shaping and the 20 Hz command loop.
 *
 * - `shapeStick` maps a stick (x right, y down as in WebXR and the Gamepad API) to (linear, angular) scaled
 *   to the robot's limits from `hello`, with a radial dead-zone and an expo curve: forward/back is linear,
 *   left/right is angular (left = counter-clockwise = positive, REP 103).
 * - `TeleopLoop` owns one robot at a time and one input source at a time ("never two sources for one
 *   robot"). While the stick is outside the dead-zone it emits a command every 50 ms; on release, and on
 *   every `stop` (robot or mode switch, menu opened, tab hidden, session end, disconnect), it emits exactly
 *   one zero command if the robot was being driven. After a stop the stick must come back to the centre
 *   before it drives again, so a stick held through a menu or a reconnect does not lurch the robot.
 */

export const TELEOP_RATE_HZ = 20;
export const TELEOP_PERIOD_MS = 1000 / TELEOP_RATE_HZ;
export const DEFAULT_DEADZONE = 0.15;
export const DEFAULT_EXPO = 0.4;

/** @typedef {import('./protocol.js').Limits} Limits the robot's limits from hello */
/** @typedef {{robot: string, linear: number, angular: number}} TeleopCommand */

/**
 * @param {number} x stick right (+) / left (-), -1..1
 * @param {number} y stick down/back (+) / up/forward (-), -1..1
 * @param {Limits} limits
 * @param {{deadzone?: number, expo?: number}} [options]
 * @returns {{linear: number, angular: number}}
 */
export function shapeStick(x, y, limits, options = {}) {
  const deadzone = options.deadzone ?? DEFAULT_DEADZONE;
  const expo = options.expo ?? DEFAULT_EXPO;
  const r = Math.hypot(x, y);
  if (!(r > deadzone)) return { linear: 0, angular: 0 };
  // Radial dead-zone: rescale the remaining travel to 0..1 so that there is no jump at its edge.
  const t = Math.min(1, (r - deadzone) / (1 - deadzone));
  const shaped = (1 - expo) * t + expo * t * t * t;
  const k = shaped / r;
  const linear = -y * k * limits.linear;
  const angular = -x * k * limits.angular;
  // Clamp each component: a diagonal of a square gate can exceed 1 on one axis after scaling.
  return {
    linear: clamp(linear, limits.linear) + 0, // + 0 turns -0 into 0 for the wire
    angular: clamp(angular, limits.angular) + 0,
  };
}

/**
 * When the command after one due at `due` and sent at `now` is due: a fixed cadence, and after a stall (or at the
 * start of a drive) it restarts from now, never bursting. The page's loop and the socket worker's clock
 * (teleop_hold.js) both keep time with it.
 * @param {number} due @param {number} now @param {number} period ms
 */
export function nextDue(due, now, period) {
  const scheduled = due + period;
  return scheduled > now ? scheduled : now + period;
}

/** @param {number} v @param {number} limit */
function clamp(v, limit) {
  return Math.max(-limit, Math.min(limit, v));
}

export class TeleopLoop {
  /** @param {{period?: number}} [options] */
  constructor(options = {}) {
    this.period = options.period ?? TELEOP_PERIOD_MS;
    /** @type {string | null} the robot being driven */
    this.robot = null;
    /** @type {Limits} */
    this.limits = { linear: 0, angular: 0 };
    /** @type {string | null} the input that holds the robot */
    this.source = null;
    this.command = { linear: 0, angular: 0 };
    /** A non-zero command went out since the last zero: a release or stop owes one zero. */
    this.driving = false;
    /** After a stop, input is ignored until it comes back inside the dead-zone. */
    this.armed = true;
    this.nextDue = 0;
    this.sent = 0;
    /** @type {TeleopCommand | null} */
    this.lastCommand = null;
  }

  /**
   * Drive this robot (or none). Switching robot stops the previous one first.
   * @param {string | null} robot @param {Limits} limits @param {number} now ms
   * @returns {TeleopCommand[]}
   */
  setRobot(robot, limits, now) {
    if (robot === this.robot) {
      this.limits = limits;
      return [];
    }
    const out = this.stop(now);
    this.robot = robot;
    this.limits = limits;
    return out;
  }

  /**
   * The current reading of one input source, shaped already. A source other than the holder is ignored
   * while the holder deflects its stick; a centred holder releases the robot to whichever source moves.
   * @param {string} source @param {number} linear @param {number} angular @param {number} now ms
   * @returns {TeleopCommand[]} commands to send now (the first of a drive, or the zero of a release)
   */
  input(source, linear, angular, now) {
    if (this.robot === null) return [];
    const active = linear !== 0 || angular !== 0;
    if (this.source !== null && this.source !== source) return []; // held by another source
    if (!this.armed) {
      if (active) return [];
      this.armed = true;
    }
    if (active) {
      this.source = source;
      const wasIdle = this.command.linear === 0 && this.command.angular === 0;
      this.command = { linear, angular };
      // The first command of a drive goes out at once; then the fixed rate takes over.
      if (wasIdle && now >= this.nextDue) return [this.#emit(now)];
      return [];
    }
    if (this.source === source) {
      this.command = { linear: 0, angular: 0 };
      return this.#release(now);
    }
    return [];
  }

  /**
   * Called often (every frame or a timer); emits the held command when 50 ms have passed.
   * @param {number} now ms @returns {TeleopCommand[]}
   */
  tick(now) {
    if (this.robot === null || (this.command.linear === 0 && this.command.angular === 0)) return [];
    if (now < this.nextDue) return [];
    return [this.#emit(now)];
  }

  /**
   * Stop driving at once (switch of robot or mode, menu opened, tab hidden, session end, disconnect,
   * E-STOP). Emits one zero command if the robot was moving; input must re-centre before driving again.
   * @param {number} now ms @returns {TeleopCommand[]}
   */
  stop(now) {
    const wasActive = this.command.linear !== 0 || this.command.angular !== 0;
    this.command = { linear: 0, angular: 0 };
    if (wasActive) this.armed = false;
    return this.#release(now);
  }

  /** @param {number} now @returns {TeleopCommand[]} */
  #release(now) {
    this.source = null;
    if (!this.driving || this.robot === null) return [];
    this.driving = false;
    return [this.#record({ robot: this.robot, linear: 0, angular: 0 })];
  }

  /** @param {number} now */
  #emit(now) {
    this.nextDue = nextDue(this.nextDue, now, this.period);
    this.driving = true;
    return this.#record({ robot: /** @type {string} */ (this.robot), ...this.command });
  }

  /** @param {TeleopCommand} command */
  #record(command) {
    this.sent++;
    this.lastCommand = command;
    return command;
  }
}

/**
 * Keys held to a virtual stick: forward W/ArrowUp, back S/ArrowDown, left A/ArrowLeft, right D/ArrowRight.
 * @param {Set<string>} codes KeyboardEvent.code values held down
 * @returns {[number, number]} x, y like a gamepad stick (y forward is negative)
 */
export function keysToStick(codes) {
  const has = (/** @type {string[]} */ ...keys) => keys.some((k) => codes.has(k));
  const x = (has('KeyD', 'ArrowRight') ? 1 : 0) - (has('KeyA', 'ArrowLeft') ? 1 : 0);
  const y = (has('KeyS', 'ArrowDown') ? 1 : 0) - (has('KeyW', 'ArrowUp') ? 1 : 0);
  return [x, y];
}
