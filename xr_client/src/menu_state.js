// @ts-check
/**
 * The floating menu as a state machine, without DOM or WebGL: the VR panel and the desktop overlay both
 * render `buttons()` and feed `press(id)`; the application carries out the returned effects.
 *
 * Rules:
 * - mode `free_roam` | `pov`; `pov` needs a selected robot with a camera;
 * - robots are a radio group where pressing the selected one selects none; more than a row holds are paged
 *   (robot_pages.js: `‹` / `›` turn the pages), the selected robot's page shown when it is selected or the menu opens;
 * - tools `teleop`, `goal` and `inspect` are exclusive; teleop and goal need a selected robot and an operator
 *   connection; `goal` and `inspect` only in free roam (there is no floor in the POV space); `inspect` (point at
 *   pins, rings and the floor) needs no robot, and serves viewers too (they review, they change nothing);
 * - `Inspect picked (N)` is offered once targets are picked, for the selected robot or the fleet;
 * - `Snapshot` / `Live` only in POV; `Live` is a switch;
 * - the open alerts (the newest two, and how many more) are a row of their own while there are any, each button
 *   acknowledging its alert: in VR as on the desktop, so an alert is never out of sight in the headset;
 * - `All findings` / `Changed since last round` is a pair, a row of its own while some finding changed since its
 *   target's last round (or the switch is on); the second, pressed again, is the first: with the
 *   second, the pins (and the desktop's findings list) show only what changed since each target's last round
 *   (change_colour.js), the same switch as the findings panel's;
 * - a study's question asked now (its words, its answers, Back, Next and Send) heads the menu; in VR the panel then
 *   shows only it and E-STOP (`panelButtons`), the desktop its own study panel instead;
 * - E-STOP (every robot) is always there, with `Stop <robot>` for the selected one; while an emergency stop is
 *   latched, `Reset E-STOP` sits beside them;
 * - every change that ends driving (robot or mode switch, tool off, E-STOP, menu opened) asks for a
 *   teleop stop, which the teleop loop turns into one zero command if the robot was being driven.
 */
import { may } from './roles.js';
import { MAX_STREAM_FPS } from './protocol.js';
import { menuButtons } from './menu_buttons.js';
import { MenuOptions } from './menu_options.js';
import { RobotPages } from './robot_pages.js';

/** @typedef {'free_roam' | 'pov'} Mode */
/** @typedef {'none' | 'teleop' | 'goal' | 'inspect'} Tool */
/** @typedef {{name: string, hasCamera: boolean}} MenuRobot */
/** @typedef {'start' | 'all' | 'picked' | 'pause' | 'resume' | 'abort'} MissionAction */
/**
 * A button of the menu; a caption is words among the buttons, drawn without a button's face ("robots 1-6 of 20").
 * @typedef {{id: string, label: string, group: string, active: boolean, enabled: boolean, danger?: boolean,
 *   caption?: boolean}} MenuButton
 */
/**
 * @typedef {{type: 'menu', open: boolean}
 *   | {type: 'mode', mode: Mode}
 *   | {type: 'stop_teleop', robot: string}
 *   | {type: 'stream', robot: string, fps: number}
 *   | {type: 'snapshot', robot: string}
 *   | {type: 'estop', robot?: string}
 *   | {type: 'estop_reset'}
 *   | {type: 'select', robot: string | null}
 *   | {type: 'cancel', robot: string}
 *   | {type: 'takeover', robot: string, holder: string}
 *   | {type: 'tool', tool: Tool}
 *   | {type: 'mission', action: MissionAction, robot: string | null}
 *   | {type: 'alert_ack', alert: string}
 *   | {type: 'study_press', id: string}
 *   | {type: 'since_last_round', on: boolean}} MenuEffect
 */
/** @typedef {{alert: string, text: string, severity: string, robot: string | null}} MenuAlert */

/** @typedef {import('./protocol.js').Role} Role */

export class MenuState {
  constructor() {
    this.open = false;
    this.mode = /** @type {Mode} */ ('free_roam');
    this.selected = /** @type {string | null} */ (null);
    this.tool = /** @type {Tool} */ ('none');
    this.live = false;
    /** The operator's options: seated, smooth move, overview, scans, gaze press, and the sound's (menu_options.js). */
    this.options = new MenuOptions();
    this.robots = /** @type {MenuRobot[]} */ ([]);
    this.robotPages = new RobotPages(); // the VR row's page of robots, in a large fleet (robot_pages.js)
    /** This page's role (relay/accounts/roles.py): what the buttons offer (roles.js). @type {Role} */
    this.role = 'operator';
    this.connected = false;
    /** The selected robot follows a goal (from its status): `Cancel goal` is enabled. */
    this.goalActive = false;
    /** Robots whose emergency stop is latched (from their statuses): they cannot be driven or sent
     * anywhere, and `Reset E-STOP` is offered. @type {string[]} */
    this.latched = [];
    /** The study's question asked now (`show('question', ...)`), its words and answers the VR panel's first rows.
     * @type {import('./study_model.js').MenuQuestion | null} */
    this.question = null;
    /** The selected robot's mission, if it is on one (`Pause`/`Resume` and `Abort mission` are offered).
     * @type {'running' | 'paused' | null} */
    this.mission = null;
    /** Who holds the selected robot when it is not this operator ("Ana", "a mission"), or null: Teleop is off
     * for it and `Take over` is offered (Goal stays: its click offers the take-over). @type {string | null} */
    this.holder = null;
    /** How many targets are picked for a new mission (from the inspection review). */
    this.picked = 0;
    /** The alerts nobody acknowledged, newest first (from the inspection model). @type {MenuAlert[]} */
    this.alerts = [];
    /** Whether pins show only what changed since the last round (the model's switch), and how many findings did. */
    this.sinceLastRound = false;
    this.changed = 0;
    /** Increments on every change, so that views redraw only when something changed. */
    this.version = 0;
  }

  /**
   * The fleet from `hello` (also after a reconnect: the selection survives when the robot still exists,
   * and a live stream is asked for again on the new connection).
   * @param {MenuRobot[]} robots @param {Role} role @returns {MenuEffect[]}
   */
  setFleet(robots, role) {
    this.robots = robots.map((r) => ({ ...r }));
    this.role = role;
    this.connected = true;
    /** @type {MenuEffect[]} */
    const effects = [];
    if (this.selected !== null && !this.robot(this.selected)) {
      effects.push(...this.#select(null));
    } else if (this.mode === 'pov' && !this.robot(this.selected)?.hasCamera) {
      effects.push(...this.#setMode('free_roam'));
    }
    if (!this.operator && this.#moves()) effects.push(...this.#setTool('none'));
    if (this.live && this.selected) effects.push({ type: 'stream', robot: this.selected, fps: MAX_STREAM_FPS });
    this.#changed();
    return effects;
  }

  /** @param {boolean} connected */
  setConnected(connected) {
    if (this.connected === connected) return;
    this.connected = connected;
    this.#changed();
  }

  /** @param {string | null} name */
  robot(name) {
    return this.robots.find((r) => r.name === name) ?? null;
  }

  /** The robots whose emergency stop is latched (their statuses). @param {string[]} robots */
  setLatched(robots) {
    if (robots.join() === this.latched.join()) return;
    this.latched = [...robots];
    // A tool of a latched robot would only earn refusals: it goes off (the estop already stopped teleop).
    if (this.selected !== null && this.latched.includes(this.selected) && this.#moves()) this.tool = 'none';
    this.#changed();
  }

  get estopped() {
    return this.latched.length > 0;
  }

  /**
   * Who holds the selected robot, if not this operator (its status and the operators' names).
   * @param {string | null} holder
   */
  setHolder(holder) {
    if (holder === this.holder) return;
    this.holder = holder;
    if (holder !== null && this.tool === 'teleop') this.tool = 'none'; // the relay already stopped this teleop
    this.#changed();
  }

  /**
   * News from the relay the menu shows: whether the selected robot follows a goal (its status), its mission's state
   * (`running`, `paused` or null), how many targets are picked, the open alerts newest first (the inspection
   * model's, the same objects while unchanged). Redrawn only when it changes.
   * @param {'goalActive' | 'mission' | 'picked' | 'alerts' | 'sinceLastRound' | 'changed' | 'question'} key
   * @param {any} value
   */
  show(key, value) {
    if (same(/** @type {any} */ (this)[key], value)) return;
    /** @type {any} */ (this)[key] = value;
    this.#changed();
  }

  /** Whether this page drives robots (teleop, goals, leases): an operator's or an admin's. */
  get operator() {
    return may(this.role, 'drive');
  }

  get canCommand() {
    return this.operator && this.connected;
  }

  /** Open or close (one controller button press). @returns {MenuEffect[]} */
  toggle() {
    return this.setOpen(!this.open);
  }

  /** @param {boolean} open @returns {MenuEffect[]} */
  setOpen(open) {
    if (open === this.open) return [];
    this.open = open;
    if (open) this.robotPages.show(this.robots.findIndex((r) => r.name === this.selected));
    this.#changed();
    /** @type {MenuEffect[]} */
    const effects = [{ type: 'menu', open }];
    // The sticks and triggers now work the menu: whatever robot was being driven stops.
    if (open && this.tool === 'teleop' && this.selected) effects.unshift({ type: 'stop_teleop', robot: this.selected });
    return effects;
  }

  /** What the menu shows now (menu_buttons.js). @returns {MenuButton[]} */
  buttons() {
    return menuButtons(this);
  }

  /**
   * A button was pressed (disabled buttons do nothing).
   * @param {string} id
   * @returns {MenuEffect[]}
   */
  press(id) {
    const button = this.buttons().find((b) => b.id === id);
    if (!button || !button.enabled) return [];
    /** @type {MenuEffect[]} */
    let effects = [];
    const [kind, arg] = id.includes(':') ? [id.slice(0, id.indexOf(':')), id.slice(id.indexOf(':') + 1)] : [id, ''];
    const requested = requestEffects(id, kind, arg, this);
    if (requested) effects = requested;
    else if (kind === 'mode') effects = this.#setMode(/** @type {Mode} */ (arg));
    else if (kind === 'robot') effects = this.#select(this.selected === arg ? null : arg);
    else if (kind === 'tool') effects = this.#setTool(this.tool === arg ? 'none' : /** @type {Tool} */ (arg));
    else if (id === 'camera:live' && this.selected) {
      this.live = !this.live;
      effects = [{ type: 'stream', robot: this.selected, fps: this.live ? MAX_STREAM_FPS : 0 }];
    } else if (kind === 'opt') this.options.press(id);
    else if (kind === 'robots') this.robotPages.turn(arg, this.robots.length);
    else if (id === 'menu:close') effects = this.setOpen(false);
    else if (id === 'estop') effects = [...(this.#moves() ? this.#setTool('none') : []), { type: 'estop' }];
    else if (id === 'estop:robot' && this.selected)
      effects = [...(this.#moves() ? this.#setTool('none') : []), { type: 'estop', robot: this.selected }];
    else if (kind === 'findings') {
      this.sinceLastRound = id === 'findings:since' && !this.sinceLastRound; // pressed again: all findings
      effects = [{ type: 'since_last_round', on: this.sinceLastRound }];
    }
    this.#changed();
    return effects;
  }

  /** Select a robot directly (desktop click on a robot, or pointing at it). @param {string | null} name */
  select(name) {
    const effects = this.#select(name);
    this.#changed();
    return effects;
  }

  /** Whether the tool moves a robot (teleop, goal): the tools an estop or a lost robot turn off. */
  #moves() {
    return this.tool === 'teleop' || this.tool === 'goal';
  }

  /** Stop driving when the robot or mode changes: one effect, or none. @returns {MenuEffect[]} */
  #stopDriving() {
    return this.tool === 'teleop' && this.selected ? [{ type: 'stop_teleop', robot: this.selected }] : [];
  }

  /** @returns {MenuEffect[]} */
  #stopLive() {
    if (!this.live || !this.selected) return [];
    this.live = false;
    return [{ type: 'stream', robot: this.selected, fps: 0 }];
  }

  /** @param {string | null} name @returns {MenuEffect[]} */
  #select(name) {
    if (name !== null && !this.robot(name)) return [];
    if (name === this.selected) return [];
    const effects = [...this.#stopDriving(), ...this.#stopLive()];
    this.selected = name;
    this.robotPages.show(this.robots.findIndex((r) => r.name === name));
    this.goalActive = false; // until the new robot's status says otherwise
    this.holder = null; // likewise
    effects.push({ type: 'select', robot: name });
    if (name === null && this.#moves()) {
      this.tool = 'none';
      effects.push({ type: 'tool', tool: 'none' });
    }
    if (this.mode === 'pov') {
      if (name !== null && this.robot(name)?.hasCamera) effects.push({ type: 'snapshot', robot: name });
      else effects.push(...this.#setMode('free_roam'));
    }
    return effects;
  }

  /** @param {Mode} mode @returns {MenuEffect[]} */
  #setMode(mode) {
    if (mode === this.mode) return [];
    if (mode === 'pov' && !this.robot(this.selected)?.hasCamera) return [];
    /** @type {MenuEffect[]} */
    const effects = [...this.#stopDriving(), ...this.#stopLive()];
    if (mode === 'pov' && this.tool === 'goal') {
      this.tool = 'none';
      effects.push({ type: 'tool', tool: 'none' });
    }
    this.mode = mode;
    effects.push({ type: 'mode', mode });
    if (mode === 'pov' && this.selected) effects.push({ type: 'snapshot', robot: this.selected });
    return effects;
  }

  /** @param {Tool} tool @returns {MenuEffect[]} */
  #setTool(tool) {
    if (tool === this.tool) return [];
    const effects = this.tool === 'teleop' ? this.#stopDriving() : [];
    this.tool = tool;
    effects.push({ type: 'tool', tool });
    return effects;
  }

  #changed() {
    this.version++;
  }
}

/**
 * What a press asks of the application and changes nothing in the menu: a goal cancelled, a take-over offered, a
 * snapshot, an E-STOP's reset asked, a mission's command, an alert acknowledged, a study's answer; else null.
 * @param {string} id @param {string} kind @param {string} arg @param {MenuState} menu @returns {MenuEffect[] | null}
 */
function requestEffects(id, kind, arg, menu) {
  const robot = menu.selected;
  if (id === 'goal:cancel' && robot) return [{ type: 'cancel', robot }];
  if (id === 'lease:take' && robot && menu.holder) return [{ type: 'takeover', robot, holder: menu.holder }];
  if (id === 'camera:snapshot' && robot) return [{ type: 'snapshot', robot }];
  if (id === 'estop:reset') return [{ type: 'estop_reset' }];
  if (kind === 'mission') return missionEffects(arg, menu);
  if (kind === 'alert') return [{ type: 'alert_ack', alert: arg }];
  if (kind === 'study') return [{ type: 'study_press', id }];
  return null;
}

/**
 * What a mission button asks for: the demo mission, all targets or the picked ones (for the selected robot, or the
 * fleet), pause or resume the selected robot's mission, abort it.
 * @param {string} button the id after `mission:` @param {MenuState} menu @returns {MenuEffect[]}
 */
function missionEffects(button, menu) {
  const robot = menu.selected;
  if (button === 'demo') return [{ type: 'mission', action: 'start', robot: null }];
  if (button === 'all') return [{ type: 'mission', action: 'all', robot }];
  if (button === 'picked') return [{ type: 'mission', action: 'picked', robot }];
  if (button === 'toggle') return [{ type: 'mission', action: menu.mission === 'paused' ? 'resume' : 'pause', robot }];
  if (button === 'abort') return [{ type: 'mission', action: 'abort', robot }];
  return [];
}

/** A value shown, the same as before: equal, or arrays of the same items. @param {any} before @param {any} value */
function same(before, value) {
  if (Array.isArray(value)) {
    return Array.isArray(before) && value.length === before.length && value.every((v, i) => v === before[i]);
  }
  // A study's question is built anew from every `study` message (study_model.js menuQuestion): by value, or the VR
  // menu was drawn again for each of them with nothing changed.
  if (value !== null && before !== null && typeof value === 'object' && typeof before === 'object') {
    return JSON.stringify(value) === JSON.stringify(before);
  }
  return value === before;
}

/** One press = one toggle: reports the rising edge of a button, never repeats while it is held. */
export class ButtonEdge {
  constructor() {
    this.down = false;
  }

  /** @param {boolean} pressed @returns {boolean} true once per press */
  update(pressed) {
    const rising = pressed && !this.down;
    this.down = pressed;
    return rising;
  }
}
