// @ts-check
/**
 * The desktop fallback's hands: orbit with the mouse (left drag rotates, right drag pans, the wheel zooms toward
 * the cursor), views by key (H frame the fleet, T top-down, F follow the selected robot: view/desktop_views.js),
 * fly with WASD/QE or the arrow keys when Teleop is off; click a robot to select it; with Goal on, press on
 * the floor for the position, drag for the heading, release to send; with Teleop on, WASD/arrows or a
 * gamepad's left stick drive the selected robot through the same 20 Hz loop, dead-zone and release rules (the keys:
 * view/desktop_keys.js). In Robot POV, dragging inside the POV panel looks around the hemisphere (view/pov_look.js).
 * Listeners are added in the constructor and removed in dispose().
 */
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { DesktopViews } from './desktop_views.js';
import { DesktopKeys } from './desktop_keys.js';
import { PovLook } from './pov_look.js';
import { CursorTip } from './cursor_tip.js';

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
   * @param {HTMLElement} povPanel the Robot POV panel (view/pov_look.js)
   */
  constructor(host, element, povPanel) {
    this.host = host;
    this.element = element;
    /**
     * The desktop view while VR is presenting.
     * @type {{position: THREE.Vector3, quaternion: THREE.Quaternion, target: THREE.Vector3} | null}
     */
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
    this.keys = new DesktopKeys(host, this.orbit, this.views);
    this.pov = new PovLook(povPanel, host.markPov);
    this.raycaster = new THREE.Raycaster();
    this.pointer = new THREE.Vector2();
    /** @type {number | null} the pointer whose press is placing a goal */
    this.goalPointerId = null;
    /** @type {{x: number, y: number, id: number} | null} */
    this.down = null;
    /** The robot a press in Goal mode landed on: the click selects it. @type {string | null} */
    this.selectOnUp = null;
    /** What a click would do, beside the cursor in Goal mode. */
    this.tip = new CursorTip();
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
    this.tip.show(outcome, this.host.menu.selected, e);
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

  /** Keyboard and gamepad into the teleop loop: called on key changes and by the 20 Hz timer. */
  /** Keyboard and gamepad into the teleop loop: called by the station's 100 Hz timer (view/desktop_keys.js). */
  pollTeleop() {
    this.keys.pollTeleop();
  }

  /** @param {number} dt s */
  update(dt) {
    this.tip.update(this.host.menu.tool === 'goal' && this.host.menu.mode === 'free_roam');
    this.keys.fly(dt);
    this.views.update(performance.now());
    this.orbit.update();
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
    this.keys.dispose();
    this.pov.dispose();
    this.views.dispose();
    this.orbit.dispose();
  }
}
