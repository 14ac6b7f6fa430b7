// @ts-check
/**
 * The desktop fallback's hands: orbit with the mouse (left drag rotates, right drag pans, the wheel zooms toward
 * the cursor), views by key (H frame the fleet, T top-down, F follow the selected robot: view/desktop_views.js),
 * fly with WASD/QE or the arrow keys when Teleop is off; click a robot to select it; with Goal on, press on
 * the floor for the position, drag for the heading, release to send; with Teleop on, WASD/arrows or a
 * gamepad's left stick drive the selected robot through the same 20 Hz loop, dead-zone and release rules.
 * In Robot POV, dragging inside the POV panel looks around the hemisphere. Listeners are added in the
 * constructor and removed in dispose().
 */
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { keysToStick } from '../teleop.js';
import { verdictText } from '../goal_verdict.js';
import { DesktopViews } from './desktop_views.js';

const FLY_SPEED = 4; // m/s
const PICK_RADIUS = 24; // px: a click this close to a robot selects it

export class DesktopControls {
  /**
   * @param {{camera: THREE.PerspectiveCamera, canvas: HTMLCanvasElement, menu: import('../menu_state.js').MenuState,
   *   goalPointer: import('../goal_pointer.js').GoalPointer, picking: import('./picking.js').Picking,
   *   robotViews: Map<string, import('./robot_view.js').RobotView>, actions: import('../app.js').OperatorActions,
   *   presenting: () => boolean, fleet: import('../fleet_model.js').FleetModel,
   *   markPov: (x: number, y: number) => boolean}} host what the desktop controls read
   *   and drive, and nothing more
   * @param {HTMLElement} element the canvas' container (listens in the capture phase, before OrbitControls)
   * @param {HTMLElement} povPanel
   */
  constructor(host, element, povPanel) {
    this.host = host;
    this.element = element;
    this.povPanel = povPanel;
    /** The desktop view while VR is presenting. @type {{position: THREE.Vector3, quaternion: THREE.Quaternion, target: THREE.Vector3} | null} */
    this.saved = null;
    this.orbit = new OrbitControls(host.camera, host.canvas);
    this.orbit.enableDamping = true;
    this.orbit.maxPolarAngle = Math.PI * 0.49;
    this.orbit.screenSpacePanning = false;
    // The wheel zooms toward what is under the cursor, not the orbit centre (as in RViz, Foxglove, any map).
    this.orbit.zoomToCursor = true;
    this.views = new DesktopViews({
      camera: host.camera,
      orbit: this.orbit,
      canvas: host.canvas,
      fleet: host.fleet,
      robotViews: host.robotViews,
      menu: host.menu,
    });
    /** @type {Set<string>} */
    this.keys = new Set();
    /** Keys pressed while Teleop was on: they drove the robot, and never fly the camera (an E-STOP that turns
     * Teleop off under a held W must not send the view away). Released, they are forgotten. @type {Set<string>} */
    this.driving = new Set();
    this.raycaster = new THREE.Raycaster();
    this.pointer = new THREE.Vector2();
    /** @type {number | null} the pointer whose press is placing a goal */
    this.goalPointerId = null;
    /** @type {{x: number, y: number, id: number} | null} */
    this.down = null;
    /** The robot a press in Goal mode landed on: the click selects it. @type {string | null} */
    this.selectOnUp = null;
    /** What a click would do, beside the cursor in Goal mode. */
    this.tip = document.getElementById('cursor-tip');
    this.povLook = { yaw: 0, pitch: 0, fov: 100 };
    /** @type {{x: number, y: number, yaw: number, pitch: number} | null} */
    this.povDrag = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const on = (
      /** @type {EventTarget} */ target,
      /** @type {string} */ type,
      /** @type {(e: any) => void} */ fn,
      /** @type {AddEventListenerOptions} */ options = {},
    ) => {
      target.addEventListener(type, fn, options);
      this.unlisten.push(() => target.removeEventListener(type, fn, options));
    };
    on(element, 'pointerdown', (e) => this.#pointerDown(e), { capture: true });
    on(window, 'pointermove', (e) => this.#pointerMove(e));
    on(window, 'pointerup', (e) => this.#pointerUp(e));
    on(window, 'keydown', (e) => this.#key(e, true));
    on(window, 'keyup', (e) => this.#key(e, false));
    on(window, 'blur', () => (this.keys.clear(), this.driving.clear()));
    on(povPanel, 'pointerdown', (e) => {
      this.povDrag = { x: e.clientX, y: e.clientY, yaw: this.povLook.yaw, pitch: this.povLook.pitch };
      povPanel.setPointerCapture(e.pointerId);
    });
    on(povPanel, 'pointermove', (e) => {
      if (!this.povDrag) return;
      const k = (this.povLook.fov / povPanel.clientHeight) * (Math.PI / 180);
      this.povLook.yaw = this.povDrag.yaw + (e.clientX - this.povDrag.x) * k;
      this.povLook.pitch = Math.max(-1.4, Math.min(1.4, this.povDrag.pitch + (e.clientY - this.povDrag.y) * k));
    });
    on(povPanel, 'pointerup', (e) => {
      // A click that did not drag the view: with the Inspect tool, a target where that point of the image looks.
      const drag = this.povDrag;
      this.povDrag = null;
      if (!drag || Math.hypot(e.clientX - drag.x, e.clientY - drag.y) > 4) return;
      const rect = povPanel.getBoundingClientRect();
      this.host.markPov(((e.clientX - rect.left) / rect.width) * 2 - 1, 1 - ((e.clientY - rect.top) / rect.height) * 2);
    });
    on(
      povPanel,
      'wheel',
      (e) => {
        e.preventDefault();
        this.povLook.fov = Math.max(40, Math.min(140, this.povLook.fov + e.deltaY * 0.05));
      },
      { passive: false },
    );
  }

  /** Entering VR: the headset drives the camera; the desktop view is kept to come back to. */
  suspend() {
    const camera = this.host.camera;
    this.saved = {
      position: camera.position.clone(),
      quaternion: camera.quaternion.clone(),
      target: this.orbit.target.clone(),
    };
    this.orbit.enabled = false;
    this.views.suspend();
  }

  /** Leaving VR: the desktop view as it was before. */
  resume() {
    if (this.saved) {
      this.host.camera.position.copy(this.saved.position);
      this.host.camera.quaternion.copy(this.saved.quaternion);
      this.orbit.target.copy(this.saved.target);
      this.saved = null;
    }
    this.orbit.enabled = true;
    this.views.layout(performance.now());
  }

  /** Frame the fleet (its map bounds, or around the robots) in the part of the window no panel covers. */
  frameFleet() {
    this.views.frame();
  }

  /** @param {PointerEvent} e */
  #ndc(e) {
    const rect = this.host.canvas.getBoundingClientRect();
    this.pointer.set(((e.clientX - rect.left) / rect.width) * 2 - 1, -((e.clientY - rect.top) / rect.height) * 2 + 1);
    this.raycaster.setFromCamera(this.pointer, this.host.camera);
    return this.raycaster;
  }

  /** @param {PointerEvent} e */
  #floorHit(e) {
    const hit = this.host.picking.pickTwin(this.#ndc(e));
    return hit?.floor ? this.host.picking.sceneToMapPoint(hit.point) : null;
  }

  /**
   * Aim the goal pointer where the mouse meets the twin: the point, and what a press there would do (a goal, a
   * robot's selection, or a refusal with its reason), so the cursor can say it before the click.
   * @param {PointerEvent} e @returns {import('../goal_verdict.js').GoalVerdict}
   */
  #aimGoal(e) {
    const { point, verdict } = this.host.picking.verdictAt(
      this.host.picking.pickTwin(this.#ndc(e)),
      this.host.menu.selected,
      this.host.menu.holder,
    );
    const robot = this.#robotUnder(e);
    const outcome = robot ? /** @type {const} */ ({ kind: 'select', robot }) : verdict;
    this.host.goalPointer.aim(point, outcome);
    // The same words beside the cursor: the marker's label is small seen from above the whole site.
    const tip = this.tip;
    if (tip) {
      const text =
        outcome.kind === 'goal'
          ? `goal for ${this.host.menu.selected}`
          : outcome.kind === 'none'
            ? outcome.reason
            : verdictText(outcome);
      tip.textContent = text;
      tip.dataset.kind = outcome.kind;
      tip.style.left = `${e.clientX + 16}px`;
      tip.style.top = `${e.clientY + 16}px`;
      tip.hidden = !text;
    }
    return outcome;
  }

  /** @param {PointerEvent} e */
  #pointerDown(e) {
    if (e.button !== 0 || e.target !== this.host.canvas || this.host.presenting()) return;
    this.down = { x: e.clientX, y: e.clientY, id: e.pointerId };
    this.selectOnUp = null;
    const menu = this.host.menu;
    if (menu.tool === 'goal' && menu.mode === 'free_roam') {
      const verdict = this.#aimGoal(e);
      // A press on a robot selects it, in Goal mode too (it never becomes a goal into that robot).
      if (verdict.kind === 'select') this.selectOnUp = verdict.robot;
      else if (verdict.kind === 'takeover') {
        if (this.host.goalPointer.hover) this.host.actions.offerTakeOver({ ...this.host.goalPointer.hover, yaw: null });
      } else if (verdict.kind !== 'goal') this.host.actions.say(`No goal here: ${verdict.reason}`);
      else if (this.host.goalPointer.press()) {
        // The drag is the goal's heading, not an orbit.
        this.goalPointerId = e.pointerId;
        this.orbit.enabled = false;
      }
    }
  }

  /** @param {PointerEvent} e */
  #pointerMove(e) {
    if (this.host.presenting()) return;
    const menu = this.host.menu;
    if (
      menu.tool === 'goal' &&
      menu.mode === 'free_roam' &&
      (e.target === this.host.canvas || this.goalPointerId !== null)
    )
      this.#aimGoal(e);
  }

  /** @param {PointerEvent} e */
  #pointerUp(e) {
    if (this.host.presenting()) return;
    if (this.goalPointerId === e.pointerId) {
      this.#aimGoal(e);
      const goal = this.host.goalPointer.release();
      this.goalPointerId = null;
      this.orbit.enabled = true;
      if (goal) this.host.actions.sendGoal(goal);
      this.down = null;
      return;
    }
    // A click (not a drag) on a robot, or near one (robots are small seen from afar), selects it; a shift-click on
    // the floor adds a target there.
    if (this.down && this.down.id === e.pointerId && Math.hypot(e.clientX - this.down.x, e.clientY - this.down.y) < 5) {
      const floor = e.shiftKey ? this.#floorHit(e) : null;
      if (floor) {
        this.host.actions.addTarget({ x: floor.x, y: floor.y });
        this.down = null;
        return;
      }
      // In Goal mode the press decided (a robot under it, or nothing: a refused spot near a robot selects nothing).
      const goalMode = this.host.menu.tool === 'goal' && this.host.menu.mode === 'free_roam';
      const robot = goalMode ? this.selectOnUp : this.#robotAt(e);
      if (robot) this.host.actions.selectRobot(robot);
    }
    this.down = null;
  }

  /** The robot whose model or label is under the pointer, if any. @param {PointerEvent} e */
  #robotUnder(e) {
    const hit = this.#ndc(e).intersectObjects(this.host.picking.robotTargets(true), true)[0];
    for (let o = /** @type {THREE.Object3D | null} */ (hit?.object ?? null); o; o = o.parent) {
      if (typeof o.userData.robot === 'string') return /** @type {string} */ (o.userData.robot);
    }
    return null;
  }

  /** The robot under the pointer, else the nearest one within PICK_RADIUS pixels. @param {PointerEvent} e */
  #robotAt(e) {
    const under = this.#robotUnder(e);
    if (under) return under;
    const rect = this.host.canvas.getBoundingClientRect();
    let best = null;
    let bestDistance = PICK_RADIUS;
    const p = new THREE.Vector3();
    for (const [name, view] of this.host.robotViews) {
      if (!view.group.visible) continue;
      p.copy(view.group.position)
        .setY(view.group.position.y + 0.15)
        .project(this.host.camera);
      const d = Math.hypot(
        rect.left + ((p.x + 1) / 2) * rect.width - e.clientX,
        rect.top + ((1 - p.y) / 2) * rect.height - e.clientY,
      );
      if (d < bestDistance) {
        bestDistance = d;
        best = name;
      }
    }
    return best;
  }

  /** @param {KeyboardEvent} e @param {boolean} down */
  #key(e, down) {
    const target = /** @type {HTMLElement} */ (e.target);
    const typing = Boolean(target && (target.tagName === 'INPUT' || target.tagName === 'TEXTAREA'));
    const code = e.code;
    // Space and Esc are E-STOP from anywhere on the page, a dialog open or not (a dialog that kept them would hold
    // the stop back while it waits for an answer). Space types a space only in a field whose text may have one (the
    // operator's name: data-space="text"); elsewhere it never reaches a focused button as a click. Esc keeps its
    // default too: it also cancels the dialog it was pressed in.
    if (code === 'Escape' || (code === 'Space' && !(typing && target.dataset.space === 'text'))) {
      if (code === 'Space') e.preventDefault();
      if (down && !e.repeat && !this.host.presenting()) this.host.actions.pressMenu('estop');
      return;
    }
    if (typing) return;
    const view = { KeyH: 'frame', Home: 'frame', KeyT: 'top', KeyF: 'follow' }[code];
    if (view && !e.ctrlKey && !e.metaKey && !e.altKey) {
      if (down && !e.repeat && !this.host.presenting()) this.views.choose(view);
      return;
    }
    if (
      !['KeyW', 'KeyA', 'KeyS', 'KeyD', 'KeyQ', 'KeyE', 'ArrowUp', 'ArrowDown', 'ArrowLeft', 'ArrowRight'].includes(
        code,
      )
    )
      return;
    e.preventDefault();
    if (down) this.keys.add(code);
    else this.keys.delete(code);
    if (down && this.host.menu.tool === 'teleop') this.driving.add(code);
    if (!down) this.driving.delete(code);
    if (this.host.menu.tool === 'teleop') this.pollTeleop();
  }

  /** Keyboard and gamepad into the teleop loop: called on key changes and by the 20 Hz timer. */
  pollTeleop() {
    if (this.host.menu.tool !== 'teleop' || this.host.presenting()) return;
    const [kx, ky] = keysToStick(this.keys);
    this.host.actions.driveStick('keyboard', kx, ky);
    const pad = [...(navigator.getGamepads?.() ?? [])].find((g) => g && g.mapping === 'standard' && g.connected);
    if (pad) this.host.actions.driveStick('gamepad', pad.axes[0] ?? 0, pad.axes[1] ?? 0);
  }

  /** @param {number} dt s */
  update(dt) {
    if (this.tip && !this.tip.hidden && (this.host.menu.tool !== 'goal' || this.host.menu.mode !== 'free_roam'))
      this.tip.hidden = true;
    const flying = new Set([...this.keys].filter((k) => !this.driving.has(k)));
    if (this.host.menu.tool !== 'teleop' && flying.size > 0) {
      // Fly: move the camera and its orbit target together, along the ground.
      const [x, y] = keysToStick(flying);
      const up = (flying.has('KeyE') ? 1 : 0) - (flying.has('KeyQ') ? 1 : 0);
      const forward = new THREE.Vector3();
      this.host.camera.getWorldDirection(forward);
      forward.y = 0;
      forward.normalize();
      const right = new THREE.Vector3(-forward.z, 0, forward.x);
      const step = new THREE.Vector3()
        .addScaledVector(forward, -y)
        .addScaledVector(right, x)
        .addScaledVector(new THREE.Vector3(0, 1, 0), up)
        .multiplyScalar(FLY_SPEED * dt);
      this.host.camera.position.add(step);
      this.orbit.target.add(step);
      this.views.auto = null;
    }
    this.views.update(performance.now());
    this.orbit.update();
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
    this.views.dispose();
    this.orbit.dispose();
  }
}
