// @ts-check
/**
 * The operator station: ties the connection, the behaviour modules (fleet model, menu, teleop, goal
 * pointer, sensor history) and the views (twin, robots, goals, panels, hemisphere screen, XR input,
 * desktop controls, overlay) together, and runs one frame loop for the desktop and for VR.
 *
 * Behaviour lives in the plain modules; this file carries out their decisions (menu effects, teleop
 * commands) and feeds them the relay's messages. Everything it allocates is released in dispose().
 */
import * as THREE from 'three';
import { RelayConnection, operatorToken, relayUrl } from './connection.js';
import { FleetModel } from './fleet_model.js';
import { MenuState } from './menu_state.js';
import { TeleopLoop, shapeStick } from './teleop.js';
import { GoalPointer, GoalTracker } from './goal_pointer.js';
import { SensorHistory } from './sensor_history.js';
import { PoseSmoother } from './pose_smoother.js';
import { arcPoints } from './arc.js';
import { mapToScene, mapYawToScene, sceneToMap } from './frames.js';
import { SEATED_HEIGHT_OFFSET } from './locomotion.js';
import { vrAvailability } from './security.js';
import { ModelLoader } from './view/gltf_loading.js';
import { TwinView } from './view/twin_view.js';
import { RobotView } from './view/robot_view.js';
import { GoalView } from './view/goal_view.js';
import { TeleportView, Vignette } from './view/comfort_view.js';
import { HemisphereScreen, POV_LAYER } from './view/hemisphere_screen.js';
import { FrameDecoder } from './view/frame_decoder.js';
import { MenuPanel, WristPanel } from './view/panels.js';
import { LabelSprite } from './view/label_sprite.js';
import { XRInput } from './view/xr_input.js';
import { XRInteraction } from './view/xr_interaction.js';
import { DesktopControls } from './view/desktop_controls.js';
import { Overlay } from './view/overlay.js';
import { snapshotState } from './view/state_snapshot.js';
import { FrameTimer } from './frame_timer.js';

const TIMING_SAMPLES = 1200;
/** Eye height assumed when the browser cannot place the floor ('local' reference space), metres. */
const STANDING_EYE_HEIGHT = 1.6;

export class App {
  /** Ids of snapshot requests awaiting their ack or error. @type {Set<string>} */
  pendingSnapshots = new Set();
  /** The replayed recording (`playback`, bag backend), if any. @type {{position: number, duration: number, paused: boolean} | null} */
  playback = null;
  /** The desktop camera has framed the fleet (once; a reconnect keeps the operator's view). */
  framed = false;
  /** The desktop camera before entering VR, restored after. @type {{position: THREE.Vector3, quaternion: THREE.Quaternion, target: THREE.Vector3} | null} */
  savedDesktop = null;
  /** Drawn frames (the frame loop may skip drawing outside VR, see maxFps). */
  renders = 0;
  /** The seated offset currently applied to the rig, metres. */
  appliedSeat = 0;
  /** Eye height the rig adds when the browser has no 'local-floor' reference space, metres. */
  floorOffset = 0;

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
    /** @type {Map<string, PoseSmoother>} */
    this.smoothers = new Map();
    this.connection = new RelayConnection(relayUrl(window.location, operatorToken(window.location, window.sessionStorage)));
    this.linkText = 'connecting…';
    this.linkOk = false;
    /** Ids of snapshot requests in flight, for the POV status line. */
    this.snapshots = { requested: 0, acked: 0, failed: 0, lastError: '' };
    this.commands = { goals: 0, cmdVel: 0, zeros: 0, estops: 0 };

    // -- three.js --------------------------------------------------------------------------------
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
    /** @type {Map<string, RobotView>} */
    this.robotViews = new Map();
    this.robotsKey = '';
    this.goalView = new GoalView();
    this.world.add(this.goalView.group);
    this.teleportView = new TeleportView();
    this.world.add(this.teleportView.group);
    this.vignette = new Vignette();
    this.camera.add(this.vignette.mesh);
    this.toast = new LabelSprite({ width: 900, height: 120, worldHeight: 0.09, onTop: true });
    this.toast.sprite.position.set(0, -0.18, -0.9);
    this.toast.sprite.visible = false;
    this.toastUntil = 0;
    this.camera.add(this.toast.sprite);
    this.menuPanel = new MenuPanel();
    this.scene.add(this.menuPanel.mesh, this.menuPanel.tab);
    this.wristPanel = new WristPanel();
    this.hemisphere = new HemisphereScreen(640, 640);
    this.scene.add(this.hemisphere.group);
    this.povCamera = new THREE.PerspectiveCamera(100, 4 / 3, 0.05, 50);
    this.povCamera.layers.set(POV_LAYER);
    this.hemisphere.group.add(this.povCamera);
    this.povYaw = 0;
    /** @type {{position: THREE.Vector3, yaw: number} | null} where the operator was before Robot POV */
    this.savedRig = null;
    this.decoder = new FrameDecoder(
      () => ({ width: this.hemisphere.width, height: this.hemisphere.height }),
      (bitmap, header) => this.hemisphere.show(bitmap, header),
    );
    this.xrInput = new XRInput(this.renderer, this.rig, this.scene);
    this.interaction = new XRInteraction(this);
    this.overlay = new Overlay(this);
    this.desktop = new DesktopControls(this, container, this.overlay.povPanel);
    this.raycaster = new THREE.Raycaster();

    // -- timing: JS time per frame, for the regression budget ------------------------------------
    this.frameTimer = new FrameTimer(TIMING_SAMPLES);
    this.frameCount = 0;
    this.lastFrame = performance.now();
    /** @type {XRSession | null} */
    this.session = null;
    this.sessionGeneration = 0;
    this.vr = vrAvailability({ secure: window.isSecureContext, hostname: location.hostname, port: location.port, hasXR: 'xr' in navigator, vrSupported: null });

    // -- listeners: added here, removed in dispose() ---------------------------------------------
    /** @type {(() => void)[]} */
    this.unlisten = [];
    this.#on(this.connection, 'message', (e) => this.#onMessage(/** @type {CustomEvent} */ (e).detail));
    this.#on(this.connection, 'frame', (e) => this.decoder.push(/** @type {CustomEvent} */ (e).detail));
    this.#on(this.connection, 'status', () => this.#onLink());
    this.#on(window, 'resize', () => this.#resize());
    this.#on(document, 'visibilitychange', () => {
      if (document.visibilityState === 'hidden') this.#stopDriving();
    });
    this.#on(window, 'pagehide', () => this.#stopDriving());
    this.#on(this.renderer.xr, 'sessionstart', () => this.#sessionStarted());
    this.#on(this.renderer.xr, 'sessionend', () => this.#sessionEnded());
    // Teleop runs on its own 100 Hz clock, not the frame rate: commands keep a fixed 20 Hz even when
    // frames are slow (SwiftShader in CI, a loaded desktop).
    this.teleopTimer = setInterval(() => this.#teleopTick(), 10);
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
    /** @type {boolean | null} */
    let supported = null;
    if (navigator.xr) {
      try {
        supported = await navigator.xr.isSessionSupported('immersive-vr');
      } catch {
        supported = false; // a secure-context or permissions-policy refusal
      }
    }
    this.vr = vrAvailability({ secure: window.isSecureContext, hostname: location.hostname, port: location.port, hasXR: 'xr' in navigator, vrSupported: supported });
    this.overlay.setVr(this.vr);
  }

  // -- the relay ---------------------------------------------------------------------------------

  #onLink() {
    const policy = this.connection.policy;
    const replay = this.playback
      ? ` · replay ${this.playback.position.toFixed(1)} / ${this.playback.duration.toFixed(1)} s${this.playback.paused ? ' (paused)' : ''}`
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

  /** @param {any} message */
  #onMessage(message) {
    const now = performance.now();
    const identifier = /** @type {string} */ (message.identifier);
    switch (identifier) {
      case 'hello':
        this.#onHello(message);
        return;
      case 'scene':
        this.fleet.apply(message);
        this.twin.setScene(this.fleet.scene, this.fleet.bounds);
        return;
      case 'ack':
        this.goals.acked(message.id);
        if (this.pendingSnapshots.delete(message.id)) this.snapshots.acked++;
        return;
      case 'error':
        this.#onError(message, now);
        return;
      case 'estop':
        this.teleop.stop(now);
        this.#notify(`EMERGENCY STOP: ${message.robots.join(', ')}${message.by ? ` (by ${message.by === this.fleet.clientId ? 'you' : message.by})` : ''}`, 'error');
        return;
      case 'pong':
        return;
      case 'playback':
        this.playback = message;
        this.#onLink();
        return;
      case 'backend':
        this.#notify(message.ok ? `${message.name} backend working again` : `${message.name} backend failed: ${message.message}`, message.ok ? 'info' : 'error');
        return;
    }
    if (identifier.endsWith('/lease')) {
      this.#onLease(identifier.slice(0, identifier.indexOf('/')), message);
      return;
    }
    if (identifier.endsWith('/model')) {
      const robot = identifier.slice(0, identifier.indexOf('/'));
      const entry = this.fleet.robots.get(robot);
      if (entry && entry.description.model !== message.url) {
        // The relay built this robot's model from its robot_description: swap the view for one that loads it.
        entry.description = { ...entry.description, model: message.url };
        this.robotViews.get(robot)?.dispose();
        const view = new RobotView(entry.description, this.loader);
        this.robotViews.set(robot, view);
        this.world.add(view.group);
      }
      return;
    }
    if (!this.fleet.apply(message)) {
      if (identifier.endsWith('/scan')) this.robotViews.get(identifier.slice(0, identifier.indexOf('/')))?.setScan(message);
      return;
    }
    const robot = identifier.slice(0, identifier.indexOf('/'));
    const kind = identifier.slice(identifier.indexOf('/') + 1);
    if (kind === 'pose') this.#smoother(robot).push(message.x, message.y, message.yaw, now);
    else if (kind === 'status') {
      this.goals.status(robot, message.goal, now);
      if (robot === this.menu.selected) this.menu.setGoalActive(message.goal !== null && message.goal !== undefined);
    }
    else if (kind === 'sensor' && this.history.add(robot, message.name, message.value, message.warning, now)) {
      this.#notify(`WARNING ${robot}: ${message.name} ${message.value.toFixed(1)} ${message.unit}`, 'warning');
      // A strong pulse on the wrist that carries the panel.
      this.xrInput.pulse(this.xrInput.side('left'), 0.9, 250);
    }
  }

  /** @param {any} hello */
  #onHello(hello) {
    const now = performance.now();
    this.fleet.apply(hello);
    this.playback = hello.playback ?? null;
    this.goals.reset();
    this.pendingSnapshots.clear();
    // Robot views are rebuilt only when the fleet description changed (a reconnect to the same relay
    // keeps them, and with them their loaded models).
    const key = JSON.stringify(hello.robots);
    if (key !== this.robotsKey) {
      this.robotsKey = key;
      for (const view of this.robotViews.values()) view.dispose();
      this.robotViews.clear();
      this.smoothers.clear();
      for (const entry of this.fleet.robots.values()) {
        const view = new RobotView(entry.description, this.loader);
        this.robotViews.set(entry.description.name, view);
        this.world.add(view.group);
      }
    }
    for (const [name, entry] of this.fleet.robots) {
      if (entry.pose) this.#smoother(name).push(entry.pose.x, entry.pose.y, entry.pose.yaw, now);
      if (entry.status) this.goals.status(name, entry.status.goal, now);
    }
    this.twin.setScene(this.fleet.scene, this.fleet.bounds);
    if (!this.framed) {
      // Frame the fleet once; a reconnect leaves the operator's view alone.
      this.desktop.frame(this.#fleetBox());
      this.framed = true;
    }
    const operator = this.fleet.role === 'operator';
    const effects = this.menu.setFleet(
      [...this.fleet.robots.values()].map((r) => ({ name: r.description.name, hasCamera: (r.description.cameras ?? []).length > 0 })),
      operator,
    );
    this.#apply(effects);
    this.#syncSelection();
  }

  /** The floor of the bounds, or around the robots: what the desktop camera frames first. */
  #fleetBox() {
    const box = new THREE.Box3();
    const t = this.fleet.scene.mapToScene;
    if (this.fleet.bounds) {
      const [a, b, c, d] = this.fleet.bounds;
      box.expandByPoint(new THREE.Vector3(...mapToScene(t, a, b))).expandByPoint(new THREE.Vector3(...mapToScene(t, c, d)));
    }
    for (const r of this.fleet.robots.values()) if (r.pose) box.expandByPoint(new THREE.Vector3(...mapToScene(t, r.pose.x, r.pose.y)));
    if (box.isEmpty()) box.set(new THREE.Vector3(-5, 0, -5), new THREE.Vector3(5, 0, 5));
    return box;
  }

  /**
   * Who controls a robot changed. The operator who lost one is told at once (and its teleop stops sending).
   * @param {string} robot @param {{holder: string | null, previous: string | null, reason: string}} message
   */
  #onLease(robot, message) {
    const me = this.fleet.clientId;
    if (message.previous === me && message.holder && message.holder !== me) {
      this.teleop.stop(performance.now());
      this.#notify(`${robot} was taken over by ${message.holder}`, 'error');
    } else if (message.previous === me && message.reason === 'expired') {
      this.#notify(`your control of ${robot} expired (idle)`, 'info');
    }
  }

  /**
   * A command refused because another operator holds the robot: offer to take it over (an explicit,
   * visible act: the relay stops the robot first and tells the holder). Outside VR only: a browser dialog.
   * @param {string} text
   */
  #offerTakeOver(text) {
    const robot = text.split(':')[0].split('/')[0];
    if (!this.fleet.robots.has(robot) || this.renderer.xr.isPresenting) return;
    if (globalThis.confirm?.(`${text}\n\nTake over ${robot}? It will be stopped first.`)) {
      this.connection.send({ identifier: `${robot}/lease`, action: 'acquire', force: true });
    }
  }

  /** @param {any} message @param {number} now */
  #onError(message, now) {
    if (message.code === 'leased' && message.id !== null) queueMicrotask(() => this.#offerTakeOver(message.message));
    if (this.pendingSnapshots.delete(message.id)) {
      this.snapshots.failed++;
      this.snapshots.lastError = message.code;
    }
    const shownAtMarker = this.goals.failed(message.id ?? null, message.code, message.message, now);
    this.#notify(`${message.code}: ${message.message}`, 'error', !shownAtMarker);
  }

  /**
   * The overlay's message line, and in VR a toast under the view (goal errors show at the marker instead).
   * @param {string} text @param {'info' | 'error' | 'warning'} kind @param {boolean} [toast]
   */
  #notify(text, kind, toast = true) {
    this.overlay.say(text, kind);
    if (toast) {
      this.toast.set([text], { accent: kind === 'info' ? '#3d8bff' : kind === 'warning' ? '#ffb020' : '#e02424' });
      this.toast.sprite.visible = this.presenting;
      this.toastUntil = performance.now() + 5000;
    }
  }

  /** @param {string} name */
  #smoother(name) {
    let s = this.smoothers.get(name);
    if (!s) this.smoothers.set(name, (s = new PoseSmoother()));
    return s;
  }

  // -- commands (nothing queues while disconnected) ----------------------------------------------

  /** @param {Record<string, unknown>} message @param {boolean} [withId] */
  #send(message, withId = true) {
    const id = this.connection.send(message, withId);
    if (id === null) this.#notify(`not connected: ${message.identifier} not sent`, 'error');
    return id;
  }

  /** @param {{x: number, y: number, yaw: number | null}} goal */
  sendGoal(goal) {
    const robot = this.menu.selected;
    if (!robot || this.menu.tool !== 'goal') return;
    /** @type {Record<string, unknown>} */
    const message = { identifier: `${robot}/goal_pose`, x: round(goal.x), y: round(goal.y) };
    if (goal.yaw !== null) message.yaw = round(goal.yaw);
    const id = this.#send(message);
    if (id) {
      this.commands.goals++;
      this.goals.sent(robot, goal, id, performance.now());
    }
  }

  /**
   * A stick (or keys as a stick) from one input source, shaped by the selected robot's limits.
   * @param {string} source @param {number} x @param {number} y
   */
  driveStick(source, x, y) {
    const robot = this.fleet.robot(this.menu.selected);
    if (!robot || this.menu.tool !== 'teleop') return;
    const now = performance.now();
    this.teleop.setRobot(robot.description.name, robot.description.limits, now).forEach((c) => this.#sendTwist(c));
    const { linear, angular } = shapeStick(x, y, robot.description.limits);
    this.teleop.input(source, linear, angular, now).forEach((c) => this.#sendTwist(c));
  }

  #teleopTick() {
    this.desktop.pollTeleop();
    this.teleop.tick(performance.now()).forEach((c) => this.#sendTwist(c));
  }

  /** @param {import('./teleop.js').TeleopCommand} command */
  #sendTwist(command) {
    // cmd_vel carries no id: the 20 Hz stream is not acknowledged (docs/protocol.md).
    const sent = this.connection.send({ identifier: `${command.robot}/cmd_vel`, linear: round(command.linear), angular: round(command.angular) }, false);
    if (sent === null) return;
    this.commands.cmdVel++;
    if (command.linear === 0 && command.angular === 0) this.commands.zeros++;
  }

  #stopDriving() {
    this.teleop.stop(performance.now()).forEach((c) => this.#sendTwist(c));
  }

  // -- the menu ----------------------------------------------------------------------------------

  /** @param {string} id */
  pressMenu(id) {
    this.#apply(this.menu.press(id));
  }

  toggleMenu() {
    this.#apply(this.menu.toggle());
  }

  /** @param {string} name */
  selectRobot(name) {
    this.#apply(this.menu.select(name));
  }

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
          if (camera) this.#send({ identifier: `${effect.robot}/stream`, camera: camera.name, fps: effect.fps });
          break;
        }
        case 'snapshot': {
          const camera = this.fleet.camera(effect.robot);
          const id = this.#send(camera ? { identifier: `${effect.robot}/snapshot`, camera: camera.name } : { identifier: `${effect.robot}/snapshot` });
          if (id) {
            this.snapshots.requested++;
            this.pendingSnapshots.add(id);
          }
          break;
        }
        case 'cancel':
          this.#send({ identifier: `${effect.robot}/cancel` });
          break;
        case 'estop':
          this.teleop.stop(performance.now());
          if (this.#send({ identifier: 'estop' })) this.commands.estops++;
          else this.#notify('not connected: E-STOP NOT DELIVERED', 'error');
          break;
      }
    }
  }

  /** The selected robot's camera feeds the POV screen; its teleop limits apply. */
  #syncSelection() {
    this.menu.setGoalActive(Boolean(this.fleet.robot(this.menu.selected)?.status?.goal));
    const camera = this.fleet.camera(this.menu.selected);
    const identifier = camera?.identifier ?? '';
    if (identifier !== this.decoder.accept) {
      this.decoder.setAccepted(identifier);
      this.hemisphere.clear(camera ? 'no image yet: Snapshot or Live' : 'this robot has no camera');
      this.hemisphere.calibration = camera ? { width: camera.width, height: camera.height } : null;
      if (camera) this.hemisphere.setSize(camera.width, camera.height);
      if (camera) this.hemisphere.setLens(camera.lens, camera.width, camera.height);
    }
    const robot = this.fleet.robot(this.menu.selected);
    this.teleop.setRobot(robot?.description.name ?? null, robot?.description.limits ?? { linear: 0, angular: 0 }, performance.now()).forEach((c) => this.#sendTwist(c));
  }

  /** @param {import('./menu_state.js').Mode} mode */
  #setMode(mode) {
    const pov = mode === 'pov';
    if (pov) {
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

  get presenting() {
    return this.renderer.xr.isPresenting;
  }

  async enterVR() {
    if (this.session || !navigator.xr) return;
    try {
      const session = await navigator.xr.requestSession('immersive-vr', {
        optionalFeatures: ['local-floor', 'bounded-floor', 'hand-tracking'],
      });
      this.session = session;
      // local-floor puts the origin on the floor; a browser without it gets 'local' (origin at the head)
      // and the rig makes up a standing eye height.
      try {
        await session.requestReferenceSpace('local-floor');
        this.renderer.xr.setReferenceSpaceType('local-floor');
        this.floorOffset = 0;
      } catch {
        this.renderer.xr.setReferenceSpaceType('local');
        this.floorOffset = STANDING_EYE_HEIGHT;
      }
      await this.renderer.xr.setSession(session);
    } catch (error) {
      const session = this.session;
      this.session = null;
      session?.end().catch(() => {});
      this.#notify(`could not enter VR: ${/** @type {Error} */ (error).message}`, 'error');
    }
  }

  #sessionStarted() {
    this.savedDesktop = { position: this.camera.position.clone(), quaternion: this.camera.quaternion.clone(), target: this.desktop.orbit.target.clone() };
    this.desktop.orbit.enabled = false;
    // Start standing at the south edge of the map, facing north (map +y), so the fleet is in front.
    const t = this.fleet.scene.mapToScene;
    const [minX, minY, maxX] = this.fleet.bounds ?? [-2, -2, 2];
    const [x, , z] = mapToScene(t, (minX + maxX) / 2, minY + 0.3);
    this.appliedSeat = this.menu.seated ? SEATED_HEIGHT_OFFSET : 0;
    this.rig.position.set(x, this.appliedSeat + this.floorOffset, z);
    this.rig.rotation.y = mapYawToScene(t, Math.PI / 2) - Math.PI / 2;
    this.camera.position.set(0, 0, 0);
    this.camera.quaternion.identity();
    this.menuPanel.mesh.visible = this.menu.open;
    document.body.classList.add('presenting');
    this.#applyView();
  }

  #sessionEnded() {
    this.#stopDriving();
    this.session = null;
    this.menu.setOpen(false);
    this.menuPanel.mesh.visible = false;
    this.menuPanel.tab.visible = false;
    this.wristPanel.mesh.removeFromParent();
    this.rig.position.set(0, 0, 0);
    this.rig.rotation.set(0, 0, 0);
    if (this.savedDesktop) {
      this.camera.position.copy(this.savedDesktop.position);
      this.camera.quaternion.copy(this.savedDesktop.quaternion);
      this.desktop.orbit.target.copy(this.savedDesktop.target);
    }
    this.desktop.orbit.enabled = true;
    this.savedRig = null;
    this.toast.sprite.visible = false;
    document.body.classList.remove('presenting');
    this.#applyView();
  }

  /**
   * What a pointer or a click may select a robot by: its model, and on the desktop its label too (sprites
   * need the raycaster's camera, which only the desktop's mouse ray has).
   * @param {boolean} [labels]
   */
  robotTargets(labels = false) {
    const views = [...this.robotViews.values()].filter((v) => v.group.visible);
    return labels ? views.flatMap((v) => [v.body, v.label.sprite]) : views.map((v) => v.body);
  }

  /**
   * The first thing of the twin a ray meets, and whether it counts as floor: the `floor` node, or anything
   * flat lying on it (a spill, a puddle). A goal or a teleport needs visible floor: a wall in the way blocks it.
   * @param {THREE.Raycaster} raycaster
   * @returns {{point: THREE.Vector3, floor: boolean} | null}
   */
  pickTwin(raycaster) {
    const content = this.twin.content;
    const hit = raycaster.intersectObjects(content ? [content, ...this.twin.floorTargets] : this.twin.floorTargets, true)[0];
    if (!hit) return null;
    const floors = this.twin.floorTargets;
    let floor = false;
    for (let o = /** @type {THREE.Object3D | null} */ (hit.object); o && !floor; o = o.parent) floor = floors.includes(o);
    if (!floor && hit.face) {
      const up = hit.face.normal.clone().transformDirection(hit.object.matrixWorld).y;
      floor = up > 0.7 && hit.point.y <= this.twin.box.min.y + 0.1;
    }
    return { point: hit.point, floor };
  }

  /**
   * The pointer arc from a hand to the floor (the twin's `floor` node, or the drawn floor); the arc ends at
   * whatever it meets first, and has no hit when that is not floor.
   * @param {THREE.Vector3} origin @param {THREE.Vector3} direction
   * @returns {{points: [number, number, number][], hit: THREE.Vector3 | null}}
   */
  arcToFloor(origin, direction) {
    const floorY = this.twin.box.isEmpty() ? 0 : this.twin.box.min.y;
    const { points } = arcPoints([origin.x, origin.y, origin.z], [direction.x, direction.y, direction.z], { floorY: floorY - 1, maxPoints: 64 });
    const a = new THREE.Vector3();
    const b = new THREE.Vector3();
    for (let i = 1; i < points.length; i++) {
      a.fromArray(points[i - 1]);
      b.fromArray(points[i]);
      const length = a.distanceTo(b);
      this.raycaster.set(a, b.sub(a).normalize());
      this.raycaster.far = length;
      const hit = this.pickTwin(this.raycaster);
      if (hit) return { points: [...points.slice(0, i), /** @type {[number, number, number]} */ (hit.point.toArray())], hit: hit.floor ? hit.point : null };
    }
    return { points, hit: null };
  }

  /** @param {THREE.Vector3} p a scene point @returns {{x: number, y: number}} */
  sceneToMapPoint(p) {
    const [x, y] = sceneToMap(this.fleet.scene.mapToScene, p.x, p.y, p.z);
    return { x, y };
  }

  /** Teleport so that the head lands over the target. @param {THREE.Vector3} target @param {THREE.Vector3} head */
  teleportTo(target, head) {
    this.rig.position.x += target.x - head.x;
    this.rig.position.z += target.z - head.z;
    this.rig.position.y = target.y + this.appliedSeat + this.floorOffset;
  }

  /** Snap turn about the head. @param {THREE.Vector3} head @param {number} angle */
  turnAbout(head, angle) {
    const offset = this.rig.position.clone().sub(head);
    offset.applyAxisAngle(new THREE.Vector3(0, 1, 0), angle);
    this.rig.position.set(head.x + offset.x, this.rig.position.y, head.z + offset.z);
    this.rig.rotation.y += angle;
  }

  // -- the frame ---------------------------------------------------------------------------------

  /** @param {number} _time @param {XRFrame | undefined} _frame */
  #frame(_time, _frame) {
    const start = performance.now();
    const dt = Math.min(0.1, (start - this.lastFrame) / 1000);
    this.lastFrame = start;
    this.#updateRobots(start);
    this.goalView.update(this.fleet, this.goals, start);
    if (this.presenting) {
      this.#attachWrist();
      this.interaction.update(start, dt);
      // Seated: the world is lowered under the operator (the rig raised) by a fixed amount.
      const seat = this.menu.seated ? SEATED_HEIGHT_OFFSET : 0;
      if (seat !== this.appliedSeat) {
        this.rig.position.y += seat - this.appliedSeat;
        this.appliedSeat = seat;
      }
      this.wristPanel.update(this.sensorPanelData(start));
      if (this.toast.sprite.visible && start > this.toastUntil) this.toast.sprite.visible = false;
      if (this.menu.mode === 'pov') {
        // The screen is centred on the eyes: a wide-angle image is only undistorted from its centre.
        this.camera.getWorldPosition(this.hemisphere.group.position);
        this.hemisphere.group.rotation.set(0, this.povYaw, 0);
      }
    } else {
      this.desktop.update(dt);
      this.goalView.setPointer(this.fleet.scene.mapToScene, this.menu.tool === 'goal' ? this.goalPointer.marker : null, null);
    }
    this.overlay.update(start);
    // In VR every frame is drawn: the XR framebuffer is cleared before each frame (WebXR), so a skipped
    // frame would be a blank one.
    this.frameCount++;
    if (this.presenting || start - this.lastRender >= this.minFrameMs - 1) {
      this.lastRender = start;
      this.renderer.render(this.scene, this.camera);
      if (!this.presenting && this.menu.mode === 'pov') this.#renderPov();
      // JS time of drawn frames only (update + render calls): what the frame budget is about.
      this.frameTimer.record(performance.now() - start);
      this.renders++;
    }
  }

  /** The desktop's Robot POV panel: the hemisphere seen from its centre, into the panel's rectangle. */
  #renderPov() {
    const rect = this.overlay.povRect();
    const canvas = this.renderer.domElement.getBoundingClientRect();
    if (rect.width < 2 || rect.height < 2) return;
    const x = rect.left - canvas.left;
    const y = canvas.bottom - rect.bottom;
    this.hemisphere.group.position.set(0, 0, 0);
    this.hemisphere.group.rotation.set(0, 0, 0);
    const look = this.desktop.povLook;
    this.povCamera.position.set(0, 0, 0);
    this.povCamera.rotation.set(-look.pitch, -look.yaw, 0, 'YXZ');
    this.povCamera.fov = look.fov;
    this.povCamera.aspect = rect.width / rect.height;
    this.povCamera.updateProjectionMatrix();
    this.renderer.setScissorTest(true);
    this.renderer.setScissor(x, y, rect.width, rect.height);
    this.renderer.setViewport(x, y, rect.width, rect.height);
    this.renderer.render(this.scene, this.povCamera);
    this.renderer.setScissorTest(false);
    const size = this.renderer.getSize(new THREE.Vector2());
    this.renderer.setViewport(0, 0, size.x, size.y);
  }

  #attachWrist() {
    const left = this.xrInput.side('left');
    const parent = left ? left.grip : null;
    if (parent && this.wristPanel.mesh.parent !== parent) parent.add(this.wristPanel.mesh);
  }

  /** @param {number} now */
  #updateRobots(now) {
    const t = this.fleet.scene.mapToScene;
    const selected = this.menu.selected;
    const eye = this.camera.getWorldPosition(new THREE.Vector3());
    for (const [name, view] of this.robotViews) {
      const entry = this.fleet.robots.get(name);
      if (!entry) continue;
      const pose = this.smoothers.get(name)?.sample(now);
      if (pose) {
        const [x, y, z] = mapToScene(t, pose.x, pose.y, 0);
        view.place(x, y, z, mapYawToScene(t, pose.yaw));
        view.scaleLabel(eye.distanceTo(view.group.position));
      }
      const status = entry.status;
      const controller = status?.controller ? (status.controller === this.fleet.clientId ? 'you' : status.controller) : '';
      view.setStatus({
        name,
        mode: status?.mode ?? 'unknown',
        controller,
        offline: status ? !status.online : false,
        age: status?.age ?? null,
        selected: name === selected,
        warning: this.history.robotWarning(name),
      });
    }
  }

  /** What the wrist and corner sensor panels show. @param {number} now */
  sensorPanelData(now) {
    const entry = this.fleet.robot(this.menu.selected);
    const status = entry?.status;
    return {
      robot: entry?.description.name ?? null,
      colour: entry?.description.colour ?? '#888',
      status: entry ? `${status?.online === false ? 'offline' : (status?.mode ?? '')}${status?.goal ? ` → (${status.goal.x.toFixed(1)}, ${status.goal.y.toFixed(1)})` : ''}` : '',
      link: this.linkText,
      linkOk: this.linkOk,
      sensors: (entry?.description.sensors ?? []).map((s) => {
        const reading = entry?.sensors.get(s.name);
        return { name: s.name, unit: reading?.unit ?? s.unit, value: reading?.value ?? null, warning: reading?.warning ?? false };
      }),
      history: this.history,
      now,
    };
  }

  /** The POV panel's caption. */
  povText() {
    const s = this.hemisphere;
    const robot = this.menu.selected ?? '–';
    const live = this.menu.live ? 'live' : 'snapshot';
    return s.lastIdentifier ? `${robot} · ${live} · frame ${s.lastSeq}` : `${robot} · ${this.snapshots.lastError === 'no_camera' ? 'no image yet (no_camera)' : 'waiting for an image'}`;
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

  /**
   * Where a map point (ROS, metres) appears on the desktop page, in CSS pixels (tests click there).
   * @param {number} x @param {number} y @param {number} [z]
   * @returns {[number, number]}
   */
  mapToPage(x, y, z = 0) {
    const v = new THREE.Vector3(...mapToScene(this.fleet.scene.mapToScene, x, y, z)).project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    return [rect.left + ((v.x + 1) / 2) * rect.width, rect.top + ((1 - v.y) / 2) * rect.height];
  }

  dispose() {
    this.renderer.setAnimationLoop(null);
    clearInterval(this.teleopTimer);
    this.#stopDriving();
    for (const off of this.unlisten) off();
    this.unlisten = [];
    this.session?.end().catch(() => {});
    this.connection.dispose();
    this.decoder.dispose();
    this.desktop.dispose();
    this.overlay.dispose();
    this.interaction.dispose();
    this.xrInput.dispose();
    for (const view of this.robotViews.values()) view.dispose();
    this.robotViews.clear();
    this.twin.dispose();
    this.goalView.dispose();
    this.teleportView.dispose();
    this.vignette.dispose();
    this.toast.dispose();
    this.menuPanel.dispose();
    this.wristPanel.dispose();
    this.hemisphere.dispose();
    this.loader.dispose();
    this.renderer.dispose();
    this.renderer.domElement.remove();
  }
}

/** Wire numbers: millimetres and milliradians are plenty, and the frames stay short. @param {number} v */
function round(v) {
  return Math.round(v * 1e4) / 1e4 + 0;
}
