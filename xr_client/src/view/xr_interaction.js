// @ts-check
/**
 * What the operator's hands do in VR, once per XR frame: pointer rays with hover highlight and a haptic tick on the
 * menu, select (trigger, pinch, transient-pointer) on menu buttons, the menu tab, robots and (the Inspect tool,
 * view/xr_inspection.js) pins, rings, the finding card and the floor, and the menu and its tab placed in front of
 * the operator. Its parts: the controllers' buttons (xr_buttons.js), the head's gaze dwell (xr_gaze.js), pointing
 * at the map for goals and on the overview table (xr_goal_pointing.js), the sticks, teleports and the comfort
 * vignette (xr_motion.js), and the hands' own gestures (hand_input.js).
 */
import * as THREE from 'three';
import { HandInput } from './hand_input.js';
import { XRButtons } from './xr_buttons.js';
import { GazeDwell } from './xr_gaze.js';
import { XRGoalPointing } from './xr_goal_pointing.js';
import { XRMotion } from './xr_motion.js';

const MENU_DISTANCE = 0.75;

export class XRInteraction {
  /**
   * @param {{xrInput: import('./xr_input.js').XRInput, camera: THREE.PerspectiveCamera, rig: THREE.Group,
   *   menu: import('../menu_state.js').MenuState, menuPanel: import('./panels.js').MenuPanel,
   *   goalPointer: import('../goal_pointer.js').GoalPointer, goalView: import('./goal_view.js').GoalView,
   *   teleportView: import('./comfort_view.js').TeleportView, vignette: import('./comfort_view.js').Vignette,
   *   fleet: import('../fleet_model.js').FleetModel, picking: import('./picking.js').Picking,
   *   locomotion: import('./xr_session.js').XRSessionController, actions: import('../app.js').OperatorActions,
   *   inspect: import('./xr_inspection.js').XRInspection, estop: import('./estop_view.js').EstopView,
   *   miniature: import('./miniature_view.js').MiniatureView, link: () => string}} host what the headset's
   *   interaction reads and drives, and nothing more
   */
  constructor(host) {
    this.host = host;
    this.raycaster = new THREE.Raycaster();
    /** The head: three.js keeps the user camera (a child of the rig) at the viewer's pose. */
    this.head = { position: new THREE.Vector3(), yaw: 0 };
    this.buttons = new XRButtons(host);
    this.gazeDwell = new GazeDwell(host);
    /** Pinch-drag teleop and the palm-up wrist button (view/hand_input.js). */
    this.handInput = new HandInput(
      { xrInput: host.xrInput, menu: host.menu, actions: host.actions, camera: host.camera },
      host.rig.parent ?? host.rig,
    );
    this.goals = new XRGoalPointing(host, this.head);
    this.motion = new XRMotion(host, this.head);
    /** @type {Map<number, string | null>} */
    this.hover = new Map();
  }

  /** @param {number} now ms @param {number} dt s */
  update(now, dt) {
    const host = this.host;
    const head = this.head;
    host.camera.getWorldPosition(head.position);
    const forward = host.camera.getWorldDirection(new THREE.Vector3());
    head.yaw = Math.atan2(-forward.x, -forward.z);
    this.buttons.update();
    this.#point();
    this.goals.update();
    this.motion.sticks(dt);
    this.handInput.update(head.yaw, now);
    this.motion.comfort(dt);
    this.#placeTab(dt);
  }

  #point() {
    const host = this.host;
    const input = host.xrInput;
    // 2. Pointing: the nearest interactive thing under each ray.
    const menu = host.menu;
    const panel = host.menuPanel;
    /** @type {THREE.Object3D[]} */
    const targets = menu.open ? [panel.mesh] : [panel.tab];
    const robotsPickable = !menu.open && menu.mode === 'free_roam' && menu.tool !== 'goal';
    if (robotsPickable) targets.push(...host.picking.robotTargets());
    targets.push(...host.inspect.pickables());
    if (!menu.open) targets.push(...host.miniature.pickables());
    this.goals.wimHits.clear();
    // The wrist E-STOP only where it is drawn: a ray meets hidden meshes too (three.js does not look at visibility),
    // and a pinch at the spot where a controller's wrist had been pressed an E-STOP nobody could see.
    if (host.estop.button.mesh.parent && drawn(host.estop.button.mesh)) targets.push(host.estop.button.mesh);
    // A transient pointer (Vision Pro's gaze-and-pinch) disconnects right after its selectend: its slot
    // still has that event to hand over, at its last pose.
    for (const slot of input.slots.filter((s) => s.source !== null || s.events.length > 0)) {
      const { origin, direction } = input.ray(slot);
      this.raycaster.set(origin, direction);
      this.raycaster.far = 20;
      const first = this.raycaster.intersectObjects(targets, true)[0] ?? null;
      /** @type {{point: THREE.Vector3, distance: number, uv?: THREE.Vector2 | null} | null} */
      let hit = first;
      let id = null;
      if (first?.object === panel.mesh && first.uv) id = panel.buttonAtUv(first.uv);
      else if (first?.object === panel.tab) id = 'menu:tab';
      else if (first?.object === host.estop.button.mesh) id = 'estop';
      else if (first && host.miniature.owns(first.object)) {
        id = 'wim';
        this.goals.wimHits.set(slot.index, first);
      } else if (first) id = robotOf(first.object) ?? host.inspect.idOf(first);
      if (!first) {
        const floor = host.inspect.floorAt(this.raycaster);
        if (floor) [id, hit] = [floor.id, { point: floor.point, distance: floor.point.distanceTo(origin) }];
      }
      if (id !== (this.hover.get(slot.index) ?? null)) {
        this.hover.set(slot.index, id);
        // The haptic tick of a hovered button.
        if (id && !QUIET_HOVER.some((p) => id.startsWith(p))) input.pulse(slot, 0.25, 15);
      }
      input.showHit(slot, hit ? hit.point : null, hit ? hit.distance : 0);

      this.#select(slot, id, hit);
    }
    this.gazeDwell.update(targets);
    host.inspect.setHover([...this.hover.values()]);
    this.goals.updateCursor();
    host.estop.hover([...this.hover.values()].includes('estop'));
    const menuHover =
      [...this.hover.values()].find((h) => h && !h.startsWith('pick:') && !h.startsWith('insp:') && h !== 'menu:tab') ??
      null;
    panel.setTabHover([...this.hover.values()].includes('menu:tab'));
    panel.update(menu, menuHover, host.link());
  }

  /**
   * @param {import('./xr_input.js').InputSlot} slot @param {string | null} id what the slot's ray hovers
   * @param {{point: THREE.Vector3, uv?: THREE.Vector2 | null} | null} hit where
   */
  #select(slot, id, hit) {
    const host = this.host;
    const input = host.xrInput;
    // 3. Select: on what the ray hovers, else the goal pointer.
    for (const event of input.takeEvents(slot)) {
      if (event === 'selectstart') {
        this.goals.lastPointer = slot;
        if (id === 'menu:tab') host.actions.toggleMenu();
        else if (id?.startsWith('pick:')) host.actions.selectRobot(id.slice(5));
        else if (id === 'wim') this.goals.wimSelect(slot);
        else if (
          !id &&
          host.actions.confirmVoice(
            slot.source?.hand ? 'pinch' : slot.mode === 'transient-pointer' ? 'look and pinch' : 'trigger',
          )
        ) {
          input.pulse(slot, 0.6, 30); // a spoken goal waited: this select on nothing is its "confirm"
        } else if (id?.startsWith('insp:')) {
          input.pulse(slot, 0.6, 30);
          host.inspect.select(id, hit);
        } else if (id) {
          input.pulse(slot, 0.6, 30);
          host.actions.pressMenu(id);
        } else if (this.goals.active()) {
          this.goals.press(slot);
        } else if ((slot.source?.hand || slot.mode === 'transient-pointer') && this.motion.pinchTeleports()) {
          // Point (or look) and pinch: a pinch on nothing to select aims a teleport; letting go lands it.
          this.motion.startPinch(slot);
        }
      } else if (slot === this.motion.pinchTeleport) {
        this.motion.endPinch();
      } else if (slot === this.goals.goalSlot) {
        this.goals.release(slot);
      }
    }
  }

  /** @param {number} dt s */
  #placeTab(dt) {
    const menu = this.host.menu;
    const panel = this.host.menuPanel;
    const head = this.head.position;
    const yaw = this.head.yaw;
    // 7. The menu tab floats low in front of the operator, following the head lazily.
    const tab = panel.tab;
    tab.visible = !menu.open;
    if (tab.visible) {
      const target = new THREE.Vector3(head.x - Math.sin(yaw) * 0.55, head.y - 0.5, head.z - Math.cos(yaw) * 0.55);
      tab.position.lerp(target, tab.position.lengthSq() === 0 ? 1 : Math.min(1, dt * 3));
      tab.lookAt(head);
    }
  }

  /** What each hand points at ('left', 'right', or the slot index of a transient pointer), for tests. */
  hovered() {
    /** @type {Record<string, string | null>} */
    const out = {};
    for (const slot of this.host.xrInput.active()) {
      const key = slot.source?.targetRayMode === 'tracked-pointer' ? slot.source.handedness : String(slot.index);
      out[key] = this.hover.get(slot.index) ?? null;
    }
    return out;
  }

  /** Place the menu in front of the operator, at a comfortable distance, facing them. */
  placeMenu() {
    const host = this.host;
    const head = this.head.position;
    host.camera.getWorldPosition(head);
    const forward = host.camera.getWorldDirection(new THREE.Vector3());
    forward.y = 0;
    if (forward.lengthSq() < 1e-6) forward.set(0, 0, -1);
    forward.normalize();
    const mesh = host.menuPanel.mesh;
    mesh.position.copy(head).addScaledVector(forward, MENU_DISTANCE);
    mesh.position.y = head.y - 0.12;
    mesh.lookAt(head.x, mesh.position.y + 0.1, head.z);
    // Drawn now (a closed menu is not kept drawn): its buttons are where the first ray after opening meets them.
    host.menuPanel.update(host.menu, null, host.link());
  }

  dispose() {
    this.handInput.dispose();
    this.gazeDwell.dispose();
    this.buttons.dispose();
    this.hover.clear();
  }
}

/** Hovering these gives no haptic tick: robots, the twin's floor and the image (a tick per pixel would buzz). */
const QUIET_HOVER = ['pick:', 'insp:floor', 'insp:image', 'wim'];

/** @param {THREE.Object3D | null} object */
function robotOf(object) {
  for (let o = object; o; o = o.parent) if (typeof o.userData.robot === 'string') return `pick:${o.userData.robot}`;
  return null;
}

/** Whether an object is drawn: it and every parent visible. @param {THREE.Object3D} object */
function drawn(object) {
  for (let o = /** @type {THREE.Object3D | null} */ (object); o; o = o.parent) if (!o.visible) return false;
  return true;
}
