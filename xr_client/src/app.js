// @ts-check
/**
 * The operator station: builds the behaviour modules (fleet model, message router, command sender, menu, teleop,
 * goal pointer, sensor history) and the station's parts in src/station/ (the stage, the views, the view modes, the
 * menu's and the relay's effects, the frame loop), wires them with the page's events, and carries out the
 * operator's actions (OperatorActions: the only way a view acts on the station).
 *
 * Behaviour lives in the plain modules; each view gets a narrow host (the few objects and actions it needs, never
 * the App itself). Everything it allocates is released in dispose().
 */
import { pageConnection } from './connection.js';
import { FleetModel } from './fleet_model.js';
import { MenuState } from './menu_state.js';
import { MessageRouter } from './message_router.js';
import { CommandSender } from './command_sender.js';
import { TeleopLoop } from './teleop.js';
import { TeleopDriver } from './teleop_driver.js';
import { ArmJog, ArmSender } from './arm_jog.js';
import { GoalPointer, GoalTracker } from './goal_pointer.js';
import { SensorHistory } from './sensor_history.js';
import { ClockSync, Latency } from './latency.js';
import { pageVrAvailability, vrAvailability } from './security.js';
import { snapshotState } from './view/state_snapshot.js';
import { povCaption, sensorPanelData } from './view/captions.js';
import { Stage } from './station/stage.js';
import { StationViews } from './station/views.js';
import { ViewModes } from './station/view_modes.js';
import { MenuEffects } from './station/menu_effects.js';
import { RelayEffects } from './station/relay_effects.js';
import { FrameLoop } from './station/frame_loop.js';
import { isVoxelFrame } from './voxel_map.js';

/** @typedef {import('./command_sender.js').Goal} Goal */
/**
 * What the operator can do, as the views call it: the only way a view acts on the station.
 * @typedef {{toggleMenu: () => void, pressMenu: (id: string) => void, selectRobot: (name: string) => void,
 *   sendGoal: (goal: Goal) => void, driveStick: (source: string, x: number, y: number) => void,
 *   enterVR: () => void, addTarget: (point: {x: number, y: number}) => void,
 *   say: (text: string, toast?: boolean) => void,
 *   offerTakeOver: (goal: Goal) => void, goalTo: (robot: string, goal: Goal) => void,
 *   apply: (effects: import('./menu_state.js').MenuEffect[]) => void, talk: (down: boolean) => void,
 *   confirmVoice: (how: string) => boolean,
 *   jogArm: (linear: import('./arm_jog.js').Vec3, angular?: import('./arm_jog.js').Vec3) => void,
 *   grip: (state: string | number) => void}} OperatorActions
 */

export class App {
  /** @type {(() => void)[]} */
  unlisten = [];

  /**
   * @param {HTMLElement} container where the canvas goes
   * @param {{maxFps?: number, lowQuality?: boolean, detailedMax?: number}} [options] for software-rendered browsers
   *   (CI), where each WebGL frame holds the page for long: maxFps caps how often a frame is drawn outside VR (the
   *   behaviour keeps running every frame); lowQuality draws without multisampling at a lower resolution;
   *   detailedMax: robots drawn with their full model at most (render_quality.js)
   */
  constructor(container, options = {}) {
    this.container = container;
    // -- behaviour -------------------------------------------------------------------------------
    this.fleet = new FleetModel();
    this.menu = new MenuState();
    this.teleop = new TeleopLoop();
    this.goalPointer = new GoalPointer();
    this.goals = new GoalTracker();
    this.history = new SensorHistory();
    /** How late each robot's pose, picture and commands are (latency.js): shown on its card and the POV. */
    this.latency = new Latency(new ClockSync());
    this.connection = pageConnection(window.location, window.sessionStorage, this.latency.clock);
    const notSent = (/** @type {string} */ text) => this.views.notify(text, 'error');
    this.sender = new CommandSender(this.connection, notSent, () => performance.now(), this.latency);
    this.router = new MessageRouter({
      fleet: this.fleet,
      goals: this.goals,
      history: this.history,
      commands: this.sender,
      latency: this.latency,
    });
    const warn = (/** @type {string} */ text) => this.views.notify(text, 'warning');
    this.driver = new TeleopDriver(this.teleop, this.sender, this.connection, warn);
    /** The selected robot's arm moved by the operator's keys (arm_jog.js). */
    this.armJog = new ArmJog();
    this.armSender = new ArmSender(this.connection, notSent);
    /** @type {OperatorActions} */
    this.actions = {
      toggleMenu: () => this.menuEffects.apply(this.menu.toggle()),
      pressMenu: (id) => this.menuEffects.apply(this.menu.press(id)),
      selectRobot: (name) => this.menuEffects.apply(this.menu.select(name)),
      sendGoal: (goal) => this.#sendGoal(goal),
      driveStick: (source, x, y) => this.#driveStick(source, x, y),
      enterVR: () => this.stage.xrSession.enter(),
      addTarget: (point) => this.views.inspectionUi.addTarget(point),
      say: (text, toast = false) => this.views.notify(text, 'info', toast),
      offerTakeOver: (goal) =>
        this.menu.selected &&
        this.views.operatorUi.offer(this.menu.selected, this.menu.holder ?? 'another operator', goal),
      goalTo: (robot, goal) => this.#goalFor(robot, goal),
      apply: (effects) => this.menuEffects.apply(effects),
      talk: (down) => this.views.voice.talk(down),
      confirmVoice: (how) => this.views.voice.confirmByGesture(how),
      jogArm: (linear, angular) => this.#jogArm(linear, angular),
      grip: (state) => {
        const robot = this.#armRobot();
        if (robot) this.armSender.gripper(robot, state);
      },
    };
    // -- the station's parts ---------------------------------------------------------------------
    const { fleet, menu } = this;
    const voxels = this.router.voxels;
    /** @type {Stage} */
    this.stage = new Stage(container, options, {
      fleet,
      menu,
      voxels,
      onError: (text) => this.views.notify(text, 'error'),
    });
    /** @type {StationViews} */
    this.views = new StationViews(this.stage, {
      fleet,
      menu,
      goals: this.goals,
      goalPointer: this.goalPointer,
      sender: this.sender,
      inspection: this.router.inspection,
      actions: this.actions,
      goalFor: (robot, goal) => this.#goalFor(robot, goal),
      link: () => this.relay.linkText,
      sensorPanelData: (now) => this.sensorPanelData(now),
      povText: () => povCaption(this),
      latency: this.latency,
      study: this.router.study,
      send: (message, withId) => this.connection.send(message, withId),
    });
    this.modes = new ViewModes(this.stage, this.views, menu);
    const { sender, driver, router, goalPointer } = this;
    /** @type {MenuEffects} */
    this.menuEffects = new MenuEffects({ fleet, menu, sender, driver, goalPointer }, this.views, this.modes);
    const connection = this.connection;
    /** @type {RelayEffects} */
    this.relay = new RelayEffects(
      { fleet, menu, router, connection, driver },
      this.stage,
      this.views,
      this.menuEffects,
    );
    const { history, goals } = this;
    const frameHost = {
      fleet,
      menu,
      router,
      goalPointer,
      driver,
      history,
      goals,
      linkOk: () => this.relay.linkOk,
      povYaw: () => this.modes.povYaw,
      sensorPanelData: (/** @type {number} */ now) => this.sensorPanelData(now),
    };
    /** @type {FrameLoop} */
    this.loop = new FrameLoop(frameHost, this.stage, this.views, options.maxFps);
    this.vr = vrAvailability({
      secure: window.isSecureContext,
      hostname: location.hostname,
      port: location.port,
      hasXR: 'xr' in navigator,
      vrSupported: null,
    });
    this.#listen();
    // Input and teleop's state on a 100 Hz clock, not the frame rate; the 20 Hz commands go out from the socket
    // worker's clock (teleop_driver.js), which neither slow frames nor this thread's timers hold back.
    this.teleopTimer = setInterval(() => this.#teleopTick(), 10);
  }

  #listen() {
    const xr = this.stage.renderer.xr;
    this.#on(this.connection, 'message', (e) => this.relay.onMessage(/** @type {CustomEvent} */ (e).detail));
    this.#on(this.connection, 'frame', (e) => {
      const data = /** @type {CustomEvent} */ (e).detail;
      if (isVoxelFrame(data)) this.relay.onVoxels(data);
      else this.views.feed.push(data);
    });
    this.#on(this.connection, 'status', () => this.relay.onLink());
    this.#on(window, 'resize', () => this.stage.resize());
    this.#on(document, 'visibilitychange', () => {
      if (document.visibilityState === 'hidden') this.#stopDriving();
    });
    this.#on(window, 'pagehide', () => this.#stopDriving());
    this.#on(xr, 'sessionstart', () => this.modes.sessionStarted());
    this.#on(xr, 'sessionend', () => {
      this.#stopDriving();
      this.modes.sessionEnded();
    });
  }

  /**
   * @param {EventTarget | import('three').EventDispatcher<any>} target @param {string} type
   * @param {(e: any) => void} fn
   */
  #on(target, type, fn) {
    const t = /** @type {any} */ (target);
    t.addEventListener(type, fn);
    this.unlisten.push(() => t.removeEventListener(type, fn));
  }

  start() {
    this.connection.connect();
    this.#checkVr();
    this.stage.renderer.setAnimationLoop((time, frame) => this.loop.frame(time, frame));
  }

  /** Enter VR, or why not: a missing secure context is explained, never a silently missing button. */
  async #checkVr() {
    this.vr = await pageVrAvailability({ ask: true });
    this.views.overlay.setVr(this.vr);
  }

  get presenting() {
    return this.stage.presenting;
  }

  // -- commands (nothing queues while disconnected) ----------------------------------------------

  /** @param {Goal} goal */
  #sendGoal(goal) {
    if (this.menu.selected && this.menu.tool === 'goal') this.#goalFor(this.menu.selected, goal);
  }

  /** @param {string} robot @param {Goal} goal */
  #goalFor(robot, goal) {
    const id = this.sender.goal(robot, goal);
    if (id) this.goals.sent(robot, goal, id, performance.now());
  }

  /**
   * A stick (or keys as a stick) from one input source, shaped by the selected robot's limits.
   * @param {string} source @param {number} x @param {number} y
   */
  #driveStick(source, x, y) {
    const robot = this.fleet.robot(this.menu.selected);
    if (robot && this.menu.tool === 'teleop') this.driver.stick(source, x, y, robot.description, performance.now());
  }

  /**
   * The selected robot when it has an arm (joint states come from it), no latched E-STOP, and no other operator holds
   * it (the first twist takes a free lease, as cmd_vel does; the relay refuses one held elsewhere), else null.
   */
  #armRobot() {
    const name = this.menu.selected;
    const status = this.fleet.robot(name)?.status;
    const controller = status?.controller ?? null;
    // An E-STOP's latch holds the arm: no twist would pass (and each would come back as an error).
    if (!name || !this.router.arms.joints.has(name) || status?.estopped) return null;
    return controller === null || controller === this.fleet.clientId ? name : null;
  }

  /**
   * The arm's keys on the 100 Hz timer, or the hand holding it: twists at 20 Hz while held, one zero on release.
   * @param {import('./arm_jog.js').Vec3} linear @param {import('./arm_jog.js').Vec3} [angular]
   */
  #jogArm(linear, angular = [0, 0, 0]) {
    for (const twist of this.armJog.update(this.#armRobot(), linear, angular, performance.now()))
      this.armSender.twist(twist);
  }

  #teleopTick() {
    this.views.desktop.pollTeleop();
    this.driver.tick(performance.now());
  }

  #stopDriving() {
    this.driver.stop(performance.now());
    for (const twist of this.armJog.stop(performance.now())) this.armSender.twist(twist);
  }

  /** What the wrist and corner sensor panels show. @param {number} now */
  sensorPanelData(now) {
    return sensorPanelData(this, now);
  }

  /** Read-only state for tests and for a curious developer's console (`window.__xrRelay.state`). */
  testState() {
    return snapshotState(this);
  }

  dispose() {
    this.stage.renderer.setAnimationLoop(null);
    clearInterval(this.teleopTimer);
    this.#stopDriving();
    this.driver.dispose();
    for (const off of this.unlisten) off();
    this.unlisten = [];
    this.connection.dispose();
    this.views.dispose();
    this.stage.dispose();
  }
}
