// @ts-check
/**
 * The operator station: ties the connection, the behaviour modules (fleet model, message router, command
 * sender, menu, teleop, goal pointer, sensor history) and the views (twin, robots, goals, panels, hemisphere
 * screen, XR session and interaction, desktop controls, overlay) together, and runs one frame loop for the
 * desktop and for VR.
 *
 * Behaviour lives in the plain modules; this file carries out their effects (the router's, the menu's) and
 * gives each view a narrow host: the few objects and actions it needs, never the App itself. Everything it
 * allocates is released in dispose().
 */
import * as THREE from 'three';
import { operatorToken, pageConnection } from './connection.js';
import { InspectionUi } from './view/inspection_ui.js';
import { FleetModel } from './fleet_model.js';
import { MenuState } from './menu_state.js';
import { MessageRouter } from './message_router.js';
import { CommandSender } from './command_sender.js';
import { TeleopLoop } from './teleop.js';
import { TeleopDriver } from './teleop_driver.js';
import { GoalPointer, GoalTracker } from './goal_pointer.js';
import { SensorHistory } from './sensor_history.js';
import { pageVrAvailability, vrAvailability } from './security.js';
import { ModelLoader } from './view/gltf_loading.js';
import { TwinView } from './view/twin_view.js';
import { FleetView } from './view/fleet_view.js';
import { GoalView } from './view/goal_view.js';
import { TeleportView, Vignette } from './view/comfort_view.js';
import { HemisphereScreen, POV_LAYER } from './view/hemisphere_screen.js';
import { CameraFeed } from './view/camera_feed.js';
import { MenuPanel } from './view/panels.js';
import { XRInput } from './view/xr_input.js';
import { XRInteraction } from './view/xr_interaction.js';
import { XRInspection } from './view/xr_inspection.js';
import { FindingCard } from './view/finding_card.js';
import { VRHud } from './view/vr_hud.js';
import { OperatorUi } from './view/operator_ui.js';
import { displayName } from './operator_names.js';
import { estopBanner } from './estop_banner.js';
import { XRSessionController } from './view/xr_session.js';
import { Picking } from './view/picking.js';
import { TwinPlan } from './view/twin_plan.js';
import { DesktopControls } from './view/desktop_controls.js';
import { Overlay } from './view/overlay.js';
import { snapshotState } from './view/state_snapshot.js';
import { povCaption, sensorPanelData } from './view/captions.js';
import { FrameTimer } from './frame_timer.js';
import { VoiceControl } from './view/voice_control.js';
import { SoundControl } from './view/sound_control.js';

const TIMING_SAMPLES = 1200;
/** A part the constructor builds: see the declarations in App. */
const UNBUILT = /** @type {any} */ (null);

/**
 * What the operator can do, as the views call it: the only way a view acts on the station.
 * @typedef {{toggleMenu: () => void, pressMenu: (id: string) => void, selectRobot: (name: string) => void,
 *   sendGoal: (goal: import('./command_sender.js').Goal) => void, driveStick: (source: string, x: number, y: number) => void,
 *   enterVR: () => void, addTarget: (point: {x: number, y: number}) => void, say: (text: string, toast?: boolean) => void,
 *   offerTakeOver: (goal: import('./command_sender.js').Goal) => void, goalTo: (robot: string, goal: import('./command_sender.js').Goal) => void,
 *   apply: (effects: import('./menu_state.js').MenuEffect[]) => void, talk: (down: boolean) => void,
 *   confirmVoice: (how: string) => boolean}} OperatorActions
 */

export class App {
  /** The desktop camera has framed the fleet (once; a reconnect keeps the operator's view). */
  framed = false;
  /** Drawn frames (the frame loop may skip drawing outside VR, see maxFps). */
  renders = 0;
  /** @type {{position: THREE.Vector3, yaw: number} | null} where the operator was before Robot POV */
  savedRig = null;
  povYaw = 0;
  linkText = 'connecting…';
  linkOk = false;
  frameCount = 0;
  /** @type {(() => void)[]} */
  unlisten = [];

  // -- parts, built by #buildScene and #buildViews from the constructor (declared here for the type check;
  // UNBUILT stands in until then and is never read) ----------------------------------------------------
  /** @type {THREE.WebGLRenderer} */ renderer = UNBUILT;
  /** @type {THREE.Scene} */ scene = UNBUILT;
  /** @type {InspectionUi} */ inspectionUi = UNBUILT;
  /** @type {THREE.Group} */ rig = UNBUILT;
  /** @type {THREE.PerspectiveCamera} */ camera = UNBUILT;
  /** @type {THREE.Group} */ world = UNBUILT;
  /** @type {ModelLoader} */ loader = UNBUILT;
  /** @type {TwinView} */ twin = UNBUILT;
  /** @type {XRSessionController} */ xrSession = UNBUILT;
  /** @type {Picking} */ picking = UNBUILT;
  /** @type {GoalView} */ goalView = UNBUILT;
  /** @type {TeleportView} */ teleportView = UNBUILT;
  /** @type {Vignette} */ vignette = UNBUILT;
  /** @type {MenuPanel} */ menuPanel = UNBUILT;
  /** @type {HemisphereScreen} */ hemisphere = UNBUILT;
  /** @type {FleetView} */ fleetView = UNBUILT;
  /** @type {Map<string, import('./view/robot_view.js').RobotView>} */ robotViews = UNBUILT;
  /** @type {CameraFeed} */ feed = UNBUILT;
  /** @type {VoiceControl} */ voice = UNBUILT;
  /** @type {SoundControl} */ sound = UNBUILT;
  /** @type {XRInput} */ xrInput = UNBUILT;
  /** @type {XRInteraction} */ interaction = UNBUILT;
  /** @type {FindingCard} */ findingCard = UNBUILT;
  /** @type {XRInspection} */ xrInspection = UNBUILT;
  /** @type {VRHud} */ hud = UNBUILT;
  /** @type {OperatorUi} */ operatorUi = UNBUILT;
  /** @type {Overlay} */ overlay = UNBUILT;
  /** @type {DesktopControls} */ desktop = UNBUILT;

  /**
   * @param {HTMLElement} container where the canvas goes
   * @param {{maxFps?: number, lowQuality?: boolean}} [options] for software-rendered browsers (CI), where each
   *   WebGL frame holds the page for long: maxFps caps how often a frame is drawn outside VR (the behaviour
   *   keeps running every frame); lowQuality draws without multisampling at a lower resolution
   */
  constructor(container, options = {}) {
    this.container = container;
    this.minFrameMs = options.maxFps ? 1000 / options.maxFps : 0;
    this.lastRender = -Infinity;
    // -- behaviour -------------------------------------------------------------------------------
    this.fleet = new FleetModel();
    this.menu = new MenuState();
    this.teleop = new TeleopLoop();
    this.goalPointer = new GoalPointer();
    this.goals = new GoalTracker();
    this.history = new SensorHistory();
    this.connection = pageConnection(window.location, window.sessionStorage);
    this.sender = new CommandSender(this.connection, (text) => this.#notify(text, 'error'));
    this.router = new MessageRouter({
      fleet: this.fleet,
      goals: this.goals,
      history: this.history,
      commands: this.sender,
    });
    this.driver = new TeleopDriver(this.teleop, this.sender, this.connection, (text) => this.#notify(text, 'warning'));
    /** @type {OperatorActions} */
    this.actions = {
      toggleMenu: () => this.#apply(this.menu.toggle()),
      pressMenu: (id) => this.#apply(this.menu.press(id)),
      selectRobot: (name) => this.#apply(this.menu.select(name)),
      sendGoal: (goal) => this.#sendGoal(goal),
      driveStick: (source, x, y) => this.#driveStick(source, x, y),
      enterVR: () => this.xrSession.enter(),
      addTarget: (point) => this.inspectionUi.addTarget(point),
      say: (text, toast = false) => this.#notify(text, 'info', toast),
      offerTakeOver: (goal) =>
        this.menu.selected && this.operatorUi.offer(this.menu.selected, this.menu.holder ?? 'another operator', goal),
      goalTo: (robot, goal) => this.#goalFor(robot, goal),
      apply: (effects) => this.#apply(effects),
      talk: (down) => this.voice.talk(down),
      confirmVoice: (how) => this.voice.confirmByGesture(how),
    };
    this.#buildScene(options);
    this.#buildViews(container);
    this.frameTimer = new FrameTimer(TIMING_SAMPLES);
    this.lastFrame = performance.now();
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

  /** The renderer, the lights, the operator's rig and camera, and the world the twin and robots live in. @param {{lowQuality?: boolean}} options */
  #buildScene(options) {
    const container = this.container;
    this.renderer = new THREE.WebGLRenderer({ antialias: !options.lowQuality, powerPreference: 'high-performance' });
    this.renderer.setPixelRatio(options.lowQuality ? 0.75 : Math.min(window.devicePixelRatio, 2));
    this.renderer.setSize(container.clientWidth, container.clientHeight);
    this.renderer.xr.enabled = true;
    this.renderer.xr.setReferenceSpaceType('local-floor');
    this.renderer.xr.setFoveation(0.5);
    container.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#161b24');
    this.scene.add(new THREE.HemisphereLight('#dfe8ff', '#3a3f4a', 2.2));
    const sun = new THREE.DirectionalLight('#ffffff', 1.6);
    sun.position.set(5, 10, 4);
    this.scene.add(sun);
    /** The operator: the camera and the XR controllers ride on it; locomotion moves it. */
    this.rig = new THREE.Group();
    this.rig.name = 'rig';
    this.scene.add(this.rig);
    this.camera = new THREE.PerspectiveCamera(60, container.clientWidth / container.clientHeight, 0.05, 300);
    this.rig.add(this.camera);
    /** Everything of the twin: hidden in Robot POV's neutral space. */
    this.world = new THREE.Group();
    this.world.name = 'world';
    this.scene.add(this.world);
    this.loader = new ModelLoader(this.renderer);
    this.twin = new TwinView(this.loader);
    this.world.add(this.twin.group);
    this.fleetView = new FleetView(this.world, this.loader, this.renderer);
    this.robotViews = this.fleetView.views;
    this.picking = new Picking(this.twin, this.robotViews, this.fleet);
    const plan = new TwinPlan(this.twin, this.picking, this.fleet);
    this.xrSession = new XRSessionController(
      this.renderer,
      this.rig,
      this.camera,
      { fleet: this.fleet, menu: this.menu, plan },
      (text) => this.#notify(text, 'error'),
    );
  }

  /** The views: goals, comfort, toast, panels, the hemisphere screen, and the input of both displays. @param {HTMLElement} container */
  #buildViews(container) {
    this.goalView = new GoalView();
    this.world.add(this.goalView.group);
    this.teleportView = new TeleportView();
    this.world.add(this.teleportView.group);
    const token = operatorToken(window.location, window.sessionStorage);
    this.inspectionUi = new InspectionUi({
      world: this.world,
      model: this.router.inspection,
      sender: this.sender,
      panel: document.getElementById('findings'),
      token,
      transform: () => this.fleet.scene.mapToScene,
    });
    this.vignette = new Vignette();
    this.camera.add(this.vignette.mesh);
    this.menuPanel = new MenuPanel();
    this.scene.add(this.menuPanel.mesh, this.menuPanel.tab);
    this.hud = new VRHud(this.camera, this.scene);
    this.operatorUi = new OperatorUi({
      sender: this.sender,
      storage: window.localStorage,
      params: new URLSearchParams(location.search),
      presenting: () => this.presenting,
      sendGoal: (robot, goal) => this.#goalFor(robot, goal),
    });
    this.hemisphere = new HemisphereScreen(640, 640);
    this.scene.add(this.hemisphere.group);
    // JPEG pictures and H.264 video onto the hemisphere; a fallback from video to JPEG is said once.
    this.feed = new CameraFeed({
      hemisphere: this.hemisphere,
      sender: this.sender,
      say: (text) => this.#notify(text, 'warning'),
      params: new URLSearchParams(location.search),
    });
    const inspection = this.router.inspection; // voice: its targets are places, its missions can be paused
    this.voice = new VoiceControl({
      actions: this.actions,
      menu: this.menu,
      fleet: this.fleet,
      targets: () => [...inspection.targets.values()],
      activeMission: (r) => Boolean(inspection.active(r)),
      presenting: () => this.presenting,
      toast: (text) => this.#notify(text, 'info'),
    });
    this.sound = new SoundControl({
      fleet: this.fleet,
      menu: this.menu,
      goals: this.goals,
      camera: this.camera,
      robotViews: this.robotViews,
      inputSources: () => this.renderer.xr.getSession()?.inputSources ?? [],
    });
    this.xrInput = new XRInput(this.renderer, this.rig, this.scene);
    const { camera, rig, menu, menuPanel, goalPointer, goalView, teleportView, vignette, fleet, picking, actions } =
      this;
    this.findingCard = new FindingCard(token);
    this.scene.add(this.findingCard.mesh);
    const inspect = new XRInspection({
      ui: this.inspectionUi,
      card: this.findingCard,
      picking,
      menu,
      camera,
      screen: this.hemisphere,
      notify: (text) => this.#notify(text, 'info'),
      operator: () => menu.canCommand,
    });
    this.xrInspection = inspect;
    this.interaction = new XRInteraction({
      xrInput: this.xrInput,
      camera,
      rig,
      menu,
      menuPanel,
      goalPointer,
      goalView,
      teleportView,
      vignette,
      fleet,
      picking,
      actions,
      inspect,
      estop: this.hud.estop,
      miniature: this.hud.miniature,
      locomotion: this.xrSession,
      link: () => this.linkText,
    });
    this.overlay = new Overlay({
      menu,
      actions,
      sensorPanelData: (now) => this.sensorPanelData(now),
      povText: () => povCaption(this),
    });
    const host = {
      camera,
      canvas: this.renderer.domElement,
      menu,
      goalPointer,
      picking,
      robotViews: this.robotViews,
      actions,
      presenting: () => this.presenting,
      fleet,
      markPov: (/** @type {number} */ x, /** @type {number} */ y) => inspect.clickPov(x, y),
    };
    this.desktop = new DesktopControls(host, container, this.overlay.povPanel);
  }

  #listen() {
    this.#on(this.connection, 'message', (e) => this.#onMessage(/** @type {CustomEvent} */ (e).detail));
    this.#on(this.connection, 'frame', (e) => this.feed.push(/** @type {CustomEvent} */ (e).detail));
    this.#on(this.connection, 'status', () => this.#onLink());
    this.#on(window, 'resize', () => this.#resize());
    this.#on(document, 'visibilitychange', () => {
      if (document.visibilityState === 'hidden') this.#stopDriving();
    });
    this.#on(window, 'pagehide', () => this.#stopDriving());
    this.#on(this.renderer.xr, 'sessionstart', () => this.#sessionStarted());
    this.#on(this.renderer.xr, 'sessionend', () => this.#sessionEnded());
  }

  /** @param {EventTarget | THREE.EventDispatcher<any>} target @param {string} type @param {(e: any) => void} fn */
  #on(target, type, fn) {
    const t = /** @type {any} */ (target);
    t.addEventListener(type, fn);
    this.unlisten.push(() => t.removeEventListener(type, fn));
  }

  start() {
    this.connection.connect();
    this.#checkVr();
    this.renderer.setAnimationLoop((time, frame) => this.#frame(time, frame));
  }

  /** Enter VR, or why not: a missing secure context is explained, never a silently missing button. */
  async #checkVr() {
    this.vr = await pageVrAvailability({ ask: true });
    this.overlay.setVr(this.vr);
  }

  get presenting() {
    return this.renderer.xr.isPresenting;
  }

  // -- the relay ---------------------------------------------------------------------------------

  #onLink() {
    const policy = this.connection.policy;
    const playback = this.router.playback;
    const replay = playback
      ? ` · replay ${playback.position.toFixed(1)} / ${playback.duration.toFixed(1)} s${playback.paused ? ' (paused)' : ''}`
      : '';
    this.linkText = policy.describe(performance.now()) + (policy.state === 'connected' ? replay : '');
    this.linkOk = policy.state === 'connected';
    this.overlay.setLink(this.linkText, this.linkOk);
    if (!this.linkOk && this.menu.connected) {
      // Nothing can reach the relay: stop locally (the relay's deadman stops the robot on its side).
      this.#stopDriving();
      this.menu.setConnected(false);
    }
  }

  /** @param {import('./protocol.js').ServerMessage} message */
  #onMessage(message) {
    for (const effect of this.router.route(message, performance.now())) this.#carryOut(effect);
  }

  /** Carry out what the router decided. @param {import('./message_router.js').RouterEffect} effect */
  #carryOut(effect) {
    switch (effect.type) {
      case 'fleet':
        this.#onFleet(effect.rebuild);
        break;
      case 'scene':
        this.twin.setScene(this.fleet.scene, this.fleet.bounds);
        break;
      case 'notify':
        this.#notify(effect.text, effect.kind, effect.toast);
        break;
      case 'stop_teleop':
        this.driver.stop(performance.now(), true);
        break;
      case 'link':
        this.#onLink();
        break;
      case 'model':
        this.fleetView.rebuildOne(this.fleet, effect.robot);
        break;
      case 'scan':
        this.robotViews.get(effect.robot)?.setScan(effect.scan);
        break;
      case 'goal_state':
        if (effect.robot === this.menu.selected) this.menu.setGoalActive(effect.active);
      // falls through: a status may also say who holds the robot now
      case 'names':
        this.#syncHolder();
        break;
      case 'estop_state': {
        this.menu.setLatched(effect.latched);
        const robots = [...this.fleet.robots.keys()];
        this.overlay.setBanner(
          estopBanner(effect.latched, robots, this.router.estopBy, this.fleet.clientId, this.fleet.role === 'operator'),
        );
        this.hud.estop.show(this.overlay.banner, this.presenting);
        break;
      }
      case 'sensor_warning':
        // A strong pulse on the wrist that carries the panel.
        this.xrInput.pulse(this.xrInput.side('left'), 0.9, 250);
        break;
      case 'offer_takeover': {
        const holder = displayName(
          this.fleet.robot(effect.robot)?.status?.controller,
          this.fleet.names,
          this.fleet.clientId,
        );
        this.operatorUi.offer(effect.robot, holder || 'another operator', effect.goal);
        break;
      }
      case 'inspection':
        this.inspectionUi.update(this.menu);
        break;
      case 'nav':
        if (effect.mine || effect.robot === this.menu.selected) this.#notify(effect.text, effect.kind);
        break;
    }
  }

  /** A `hello`: views for a new fleet, the twin, the first framing, the menu's robots. @param {boolean} rebuild */
  #onFleet(rebuild) {
    if (rebuild) this.fleetView.rebuild(this.fleet);
    this.twin.setScene(this.fleet.scene, this.fleet.bounds);
    if (!this.framed) {
      // Frame the fleet once; a reconnect leaves the operator's view alone.
      this.desktop.frameFleet();
      this.framed = true;
    }
    const operator = this.fleet.role === 'operator';
    const robots = [...this.fleet.robots.values()].map((r) => ({
      name: r.description.name,
      hasCamera: (r.description.cameras ?? []).length > 0,
    }));
    this.#apply(this.menu.setFleet(robots, operator));
    this.#syncSelection();
    this.operatorUi.hello(operator);
  }

  /** Who holds the selected robot, when not this operator: the menu turns Teleop off for it and offers Take over. */
  #syncHolder() {
    const controller = this.fleet.robot(this.menu.selected)?.status?.controller;
    this.menu.setHolder(
      controller && controller !== this.fleet.clientId
        ? displayName(controller, this.fleet.names, this.fleet.clientId)
        : null,
    );
  }

  /**
   * The overlay's message line, and in VR a toast under the view (goal errors show at the marker instead).
   * @param {string} text @param {'info' | 'error' | 'warning'} kind @param {boolean} [toast]
   */
  #notify(text, kind, toast = true) {
    this.overlay.say(text, kind);
    if (toast) this.hud.toast.say(text, kind, this.presenting, performance.now());
  }

  // -- commands (nothing queues while disconnected) ----------------------------------------------

  /** @param {import('./command_sender.js').Goal} goal */
  #sendGoal(goal) {
    if (this.menu.selected && this.menu.tool === 'goal') this.#goalFor(this.menu.selected, goal);
  }

  /** @param {string} robot @param {import('./command_sender.js').Goal} goal */
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

  #teleopTick() {
    this.desktop.pollTeleop();
    this.driver.tick(performance.now());
  }

  #stopDriving() {
    this.driver.stop(performance.now());
  }

  // -- the menu ----------------------------------------------------------------------------------

  /** Carry out what the menu decided. @param {import('./menu_state.js').MenuEffect[]} effects */
  #apply(effects) {
    for (const effect of effects) {
      switch (effect.type) {
        case 'stop_teleop':
          this.#stopDriving();
          break;
        case 'menu':
          if (effect.open) this.interaction.placeMenu();
          this.menuPanel.mesh.visible = effect.open && this.presenting;
          break;
        case 'mode':
          this.#setMode(effect.mode);
          break;
        case 'select':
          this.#syncSelection();
          break;
        case 'tool':
          this.goalPointer.cancel();
          break;
        case 'stream': {
          const camera = this.fleet.camera(effect.robot);
          if (camera) this.feed.stream(effect.robot, camera, effect.fps);
          break;
        }
        case 'snapshot':
          this.sender.snapshot(effect.robot, this.fleet.camera(effect.robot)?.name ?? null);
          break;
        case 'cancel':
          this.sender.cancel(effect.robot);
          break;
        case 'takeover':
          this.operatorUi.offer(effect.robot, effect.holder, null);
          break;
        case 'estop':
          this.driver.stop(performance.now(), true);
          this.sender.estop(effect.robot);
          break;
        case 'estop_reset':
          this.sender.estopReset();
          break;
        case 'mission':
          this.inspectionUi.command(effect, this.menu);
          break;
      }
    }
  }

  /** The selected robot's camera feeds the POV screen; its teleop limits apply. */
  #syncSelection() {
    this.menu.setGoalActive(Boolean(this.fleet.robot(this.menu.selected)?.status?.goal));
    this.#syncHolder();
    this.inspectionUi.update(this.menu);
    const camera = this.fleet.camera(this.menu.selected);
    const identifier = camera?.identifier ?? '';
    if (identifier !== this.feed.accept) {
      this.feed.setAccepted(identifier);
      this.hemisphere.clear(camera ? 'no image yet: Snapshot or Live' : 'this robot has no camera');
      this.hemisphere.calibration = camera ? { width: camera.width, height: camera.height } : null;
      if (camera) this.hemisphere.setSize(camera.width, camera.height);
      if (camera) this.hemisphere.setLens(camera.lens, camera.width, camera.height);
    }
    const robot = this.fleet.robot(this.menu.selected);
    this.driver.setRobot(
      robot?.description.name ?? null,
      robot?.description.limits ?? { linear: 0, angular: 0 },
      performance.now(),
    );
  }

  /** @param {import('./menu_state.js').Mode} mode */
  #setMode(mode) {
    if (mode === 'pov') {
      this.savedRig = { position: this.rig.position.clone(), yaw: this.rig.rotation.y };
      // The user camera carries the head pose in VR too (three.js copies it there after each render,
      // relative to the rig); the XR camera's own matrixWorld would lose the rig.
      const forward = this.camera.getWorldDirection(new THREE.Vector3());
      this.povYaw = Math.atan2(-forward.x, -forward.z);
      this.desktop.povLook = { yaw: 0, pitch: 0, fov: 100 };
    } else if (this.savedRig) {
      // Free Roam returns the operator where they were.
      this.rig.position.copy(this.savedRig.position);
      this.rig.rotation.y = this.savedRig.yaw;
      this.savedRig = null;
    }
    this.#applyView();
  }

  /** World visibility and camera layers for the current mode and display. */
  #applyView() {
    const vrPov = this.presenting && this.menu.mode === 'pov';
    this.world.visible = !vrPov;
    this.hemisphere.group.visible = this.menu.mode === 'pov';
    if (vrPov) this.camera.layers.enable(POV_LAYER);
    else this.camera.layers.disable(POV_LAYER);
  }

  // -- XR ----------------------------------------------------------------------------------------

  #sessionStarted() {
    this.desktop.suspend();
    this.xrSession.placeAtStart();
    this.menuPanel.mesh.visible = this.menu.open;
    this.hud.started(this.overlay.banner);
    document.body.classList.add('presenting');
    this.#applyView();
  }

  #sessionEnded() {
    this.#stopDriving();
    this.xrSession.ended();
    this.menu.setOpen(false);
    this.menuPanel.mesh.visible = false;
    this.menuPanel.tab.visible = false;
    this.hud.ended();
    this.xrInspection.update(false);
    this.desktop.resume();
    this.savedRig = null;
    document.body.classList.remove('presenting');
    this.#applyView();
  }

  // -- the frame ---------------------------------------------------------------------------------

  /** @param {number} _time @param {XRFrame | undefined} _frame */
  #frame(_time, _frame) {
    const start = performance.now();
    const dt = Math.min(0.1, (start - this.lastFrame) / 1000);
    this.lastFrame = start;
    this.driver.tick(start); // confirms the held command to the socket worker once a frame, however slow
    const eye = this.camera.getWorldPosition(new THREE.Vector3());
    const link = !this.linkOk ? 'lost' : this.router.linkStale(true, start) ? 'quiet' : 'live';
    this.fleetView.update(start, {
      fleet: this.fleet,
      smoothers: this.router.smoothers,
      history: this.history,
      selected: this.menu.selected,
      eye,
      freshness: this.router.freshness,
      link,
      scans: this.menu.scans,
    });
    this.goalView.update(this.fleet, this.goals, start, this.router.paths);
    if (this.presenting) {
      this.interaction.update(start, dt);
      this.xrInspection.update(true);
      this.xrSession.updateSeat();
      const overview = {
        twin: this.twin,
        views: this.robotViews,
        cursor: this.interaction.wimCursor,
        transform: this.fleet.scene.mapToScene,
        show: this.menu.overview && this.menu.mode === 'free_roam',
      };
      this.hud.update(start, this.xrInput.wrist('left'), this.sensorPanelData(start), overview);
      if (this.menu.mode === 'pov') {
        // The screen is centred on the eyes: a wide-angle image is only undistorted from its centre.
        this.camera.getWorldPosition(this.hemisphere.group.position);
        this.hemisphere.group.rotation.set(0, this.povYaw, 0);
      }
    } else {
      this.desktop.update(dt);
      this.goalView.setPointer(
        this.fleet.scene.mapToScene,
        this.menu.tool === 'goal' ? this.goalPointer.marker : null,
        null,
        this.goalPointer.verdict,
      );
    }
    this.overlay.update(start);
    // In VR every frame is drawn: the XR framebuffer is cleared before each frame (WebXR), so a skipped
    // frame would be a blank one.
    this.frameCount++;
    if (this.presenting || start - this.lastRender >= this.minFrameMs - 1) {
      this.lastRender = start;
      this.renderer.render(this.scene, this.camera);
      if (!this.presenting && this.menu.mode === 'pov')
        this.hemisphere.renderInto(this.renderer, this.scene, this.overlay.povRect(), this.desktop.povLook);
      // JS time of drawn frames only (update + render calls): what the frame budget is about.
      this.frameTimer.record(performance.now() - start);
      this.renders++;
    }
  }

  /** What the wrist and corner sensor panels show. @param {number} now */
  sensorPanelData(now) {
    return sensorPanelData(this, now);
  }

  #resize() {
    const w = this.container.clientWidth;
    const h = this.container.clientHeight;
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (!this.presenting) this.renderer.setSize(w, h);
  }

  /** Read-only state for tests and for a curious developer's console (`window.__xrRelay.state`). */
  testState() {
    return snapshotState(this);
  }

  dispose() {
    this.renderer.setAnimationLoop(null);
    clearInterval(this.teleopTimer);
    this.#stopDriving();
    this.driver.dispose();
    for (const off of this.unlisten) off();
    this.unlisten = [];
    this.xrSession.dispose();
    this.connection.dispose();
    this.feed.dispose();
    this.sound.dispose();
    this.desktop.dispose();
    this.overlay.dispose();
    this.interaction.dispose();
    this.xrInput.dispose();
    this.fleetView.dispose();
    this.twin.dispose();
    this.goalView.dispose();
    this.teleportView.dispose();
    this.vignette.dispose();
    this.menuPanel.dispose();
    this.hud.dispose();
    this.hemisphere.dispose();
    this.inspectionUi.dispose();
    this.findingCard.dispose();
    this.loader.dispose();
    this.renderer.dispose();
    this.renderer.domElement.remove();
  }
}
