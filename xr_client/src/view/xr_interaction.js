// @ts-check
/**
 * What the operator's hands do in VR, once per XR frame: the menu button (one press, one toggle), pointer
 * rays with hover highlight and a haptic tick on the menu, select (trigger, pinch, transient-pointer) on
 * menu buttons, the menu tab, robots and (the Inspect tool, view/xr_inspection.js) pins, rings, the finding
 * card and the floor, the goal pointer (arc, press for the position, drag for the
 * heading, release to send) on the pointing hand, teleop on the right stick, and locomotion on the left:
 * teleport arc, snap turn, optional smooth motion, all with the comfort vignette.
 */
import * as THREE from 'three';
import { ButtonEdge } from '../menu_state.js';
import { HandInput } from './hand_input.js';
import { Dwell } from '../gestures.js';
import { SnapTurn, TeleportGesture, smoothVelocity, vignetteStrength } from '../locomotion.js';
import { goalVerdict, robotSpots } from '../goal_verdict.js';

/** xr-standard index of the upper face button (Y on the left controller, B on the right). */
export const MENU_BUTTON = 5;
/** xr-standard index of the lower face button (X on the left controller, A on the right): E-STOP, on either hand. */
export const ESTOP_BUTTON = 4;
/** A thumbstick pressed in and held: push-to-talk (view/voice_control.js). */
export const TALK_BUTTON = 3;
const MENU_DISTANCE = 0.75;
/** After a dwell acts, how far the head turns before the next can start (rad). */
const GAZE_AWAY_RAD = (5 * Math.PI) / 180;

export class XRInteraction {
  /**
   * @param {{xrInput: import('./xr_input.js').XRInput, camera: THREE.PerspectiveCamera, rig: THREE.Group,
   *   menu: import('../menu_state.js').MenuState, menuPanel: import('./panels.js').MenuPanel,
   *   goalPointer: import('../goal_pointer.js').GoalPointer, goalView: import('./goal_view.js').GoalView,
   *   teleportView: import('./comfort_view.js').TeleportView, vignette: import('./comfort_view.js').Vignette,
   *   fleet: import('../fleet_model.js').FleetModel, picking: import('./picking.js').Picking,
   *   locomotion: import('./xr_session.js').XRSessionController, actions: import('../app.js').OperatorActions,
   *   inspect: import('./xr_inspection.js').XRInspection, estop: import('./estop_view.js').EstopView,
   *   miniature: import('./miniature_view.js').MiniatureView, link: () => string}} host what the headset's interaction reads and drives, and nothing more
   */
  constructor(host) {
    this.host = host;
    this.raycaster = new THREE.Raycaster();
    /** Head-gaze dwell: a reticle at the centre of view fills while the gaze rests on a point (gestures.js). */
    this.dwell = new Dwell();
    this.reticle = new Reticle();
    host.camera.add(this.reticle.group);
    /** The gaze's direction when a dwell last acted: the next dwell waits until the head has turned away from it.
     * @type {THREE.Vector3 | null} */
    this.spentGaze = null;
    /** The dwell's last state, for the state snapshot. */
    this.gaze = { id: /** @type {string | null} */ (null), fill: 0, fired: 0 };
    /** Pinch-drag teleop and the palm-up wrist button (view/hand_input.js). */
    this.handInput = new HandInput(
      { xrInput: host.xrInput, menu: host.menu, actions: host.actions, camera: host.camera },
      host.rig.parent ?? host.rig,
    );
    /** @type {Map<number, ButtonEdge>} */
    this.menuEdges = new Map();
    /** Whether a thumbstick is held in (push-to-talk). */
    this.talking = false;
    /** What the operator's inputs are, hands or controllers, as last seen (null: not yet in VR). @type {string | null} */
    this.inputKinds = null;
    /** @type {Map<number, ButtonEdge>} */
    this.estopEdges = new Map();
    /** @type {Map<number, string | null>} */
    this.hover = new Map();
    /** @type {import('./xr_input.js').InputSlot | null} the slot holding a goal press */
    this.goalSlot = null;
    /** @type {import('./xr_input.js').InputSlot | null} */
    this.lastPointer = null;
    this.snapLeft = new SnapTurn();
    this.snapRight = new SnapTurn();
    this.teleport = new TeleportGesture();
    /** A hand (or the eyes) pinching where nothing is to select: its arc (the eyes: a straight ray) aims a teleport,
     * its release lands it. @type {import('./xr_input.js').InputSlot | null} */
    this.pinchTeleport = null;
    /** @type {THREE.Vector3 | null} */
    this.teleportHit = null;
    this.vignette = 0;
    this.lastRig = new THREE.Vector3();
    this.lastRigYaw = 0;
    this.head = new THREE.Vector3();
    this.headYaw = 0;
    /** Each slot's ray on the overview table this frame. @type {Map<number, THREE.Intersection>} */
    this.wimHits = new Map();
    /** The goal being placed was pressed on the overview table: it is dragged there too. */
    this.goalViaWim = false;
    /** Where the pointing hand meets the table, and what a press there would do (the table's cursor).
     * @type {{point: {x: number, y: number}, verdict: import('../goal_verdict.js').GoalVerdict} | null} */
    this.wimCursor = null;
  }

  /** @param {number} now ms @param {number} dt s */
  update(now, dt) {
    const host = this.host;
    // The head: three.js keeps the user camera (a child of the rig) at the viewer's pose.
    host.camera.getWorldPosition(this.head);
    const forward = host.camera.getWorldDirection(new THREE.Vector3());
    this.headYaw = Math.atan2(-forward.x, -forward.z);
    this.#menuButtons();
    this.#point();
    this.#goalPointer();
    this.#sticks(dt);
    this.handInput.update(this.headYaw, now);
    this.#comfort(dt);
    this.#placeTab(dt);
  }

  #menuButtons() {
    const host = this.host;
    const input = host.xrInput;
    // 1. The menu button: a rising edge toggles, holding it does nothing more. X or A: E-STOP, at once, whatever
    // the menu or the tool (the menu's estop button: viewers are refused the same way).
    for (const slot of input.active()) {
      if (edgeOf(this.menuEdges, slot.index).update(input.pressed(slot, MENU_BUTTON))) host.actions.toggleMenu();
      if (edgeOf(this.estopEdges, slot.index).update(input.pressed(slot, ESTOP_BUTTON)))
        host.actions.pressMenu('estop');
    }
    // 1a. Hands and controllers may swap at any moment (the operator puts the controllers down): a robot driven by
    // the stick that went away must not keep the last command, so teleop stops at once, and says so.
    const kinds = [...new Set(input.active().map((slot) => (slot.source?.hand ? 'hands' : 'controllers')))]
      .sort()
      .join(' and ');
    if (this.inputKinds !== null && kinds !== this.inputKinds && host.menu.tool === 'teleop' && host.menu.selected) {
      host.actions.apply([{ type: 'stop_teleop', robot: host.menu.selected }]);
      host.actions.say(`teleop stopped: input changed to ${kinds || 'nothing'}`, true);
    }
    this.inputKinds = kinds;
    // 1b. Push-to-talk while either thumbstick is held in.
    const talking = input.active().some((slot) => input.pressed(slot, TALK_BUTTON));
    if (talking !== this.talking) {
      this.talking = talking;
      host.actions.talk(talking);
    }
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
    this.wimHits.clear();
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
        this.wimHits.set(slot.index, first);
      } else if (first) id = robotOf(first.object) ?? host.inspect.idOf(first);
      if (!first) {
        const floor = host.inspect.floorAt(this.raycaster);
        if (floor) [id, hit] = [floor.id, { point: floor.point, distance: floor.point.distanceTo(origin) }];
      }
      if (id !== (this.hover.get(slot.index) ?? null)) {
        this.hover.set(slot.index, id);
        if (id && !QUIET_HOVER.some((p) => id.startsWith(p))) input.pulse(slot, 0.25, 15); // the haptic tick of a hovered button
      }
      input.showHit(slot, hit ? hit.point : null, hit ? hit.distance : 0);

      this.#select(slot, id, hit);
    }
    this.#gaze(targets);
    host.inspect.setHover([...this.hover.values()]);
    const onTable = input.active().find((slot) => this.wimHits.has(slot.index));
    const at = onTable ? this.#wimAt(onTable) : null;
    this.wimCursor = at ? { point: at.point, verdict: at.verdict } : null;
    host.estop.hover([...this.hover.values()].includes('estop'));
    const menuHover =
      [...this.hover.values()].find((h) => h && !h.startsWith('pick:') && !h.startsWith('insp:') && h !== 'menu:tab') ??
      null;
    panel.setTabHover([...this.hover.values()].includes('menu:tab'));
    panel.update(menu, menuHover, host.link());
  }

  /**
   * The head's gaze, for a dwell: on a point of a finding's image it selects there (a region from that point, or a
   * target where that pixel looks, as the card's mode says), and on a menu button it presses it only when the menu's
   * **Gaze press** option is on. @param {THREE.Object3D[]} targets what rays can hit now
   */
  #gaze(targets) {
    const host = this.host;
    const camera = host.camera;
    this.raycaster.set(camera.getWorldPosition(new THREE.Vector3()), camera.getWorldDirection(new THREE.Vector3()));
    this.raycaster.far = 20;
    const first = this.raycaster.intersectObjects(targets, true)[0] ?? null;
    let id = null;
    /** @type {[number, number] | null} */
    let live = null;
    if (first?.object === host.menuPanel.mesh && first.uv)
      id = host.menu.dwellPress ? host.menuPanel.buttonAtUv(first.uv) : null;
    else if (first) {
      const name = host.inspect.idOf(first);
      id = name === 'insp:image' ? name : null;
    } else if ((live = host.inspect.liveAt(this.raycaster.ray.direction))) id = 'pov:image';
    // On the live image (5 m away, around the eyes) the gaze's steadiness is judged 1 m out: 3 degrees of wander.
    const at = first ? first.point : live ? this.raycaster.ray.at(1, new THREE.Vector3()) : null;
    const point = at ? /** @type {[number, number, number]} */ (at.toArray()) : null;
    // What a dwell opens may appear under the gaze (the finding card, in front of the eyes): nothing more is dwelt
    // on until the head turns away, 5 degrees, from where the last dwell acted.
    const spent = this.spentGaze !== null && this.raycaster.ray.direction.angleTo(this.spentGaze) < GAZE_AWAY_RAD;
    if (!spent) this.spentGaze = null;
    if (spent) id = null;
    const { fill, fire } = this.dwell.update(id && point ? { id, point } : null, performance.now());
    this.reticle.setFill(fill);
    this.gaze.id = id;
    this.gaze.fill = fill;
    if (!fire || !id) return;
    this.gaze.fired++;
    this.spentGaze = this.raycaster.ray.direction.clone();
    if (id === 'pov:image' && live) host.inspect.markLive(live);
    else if (!first) return;
    else if (id === 'insp:image') host.inspect.select(id, first);
    else host.actions.pressMenu(id);
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
        this.lastPointer = slot;
        if (id === 'menu:tab') host.actions.toggleMenu();
        else if (id?.startsWith('pick:')) host.actions.selectRobot(id.slice(5));
        else if (id === 'wim') this.#wimSelect(slot);
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
        } else if (this.#goalActive()) {
          this.#aimGoal(slot);
          // The arc on a robot selects it (it never becomes a goal into that robot); a refusal says why.
          const verdict = host.goalPointer.verdict;
          if (verdict?.kind === 'select') host.actions.selectRobot(verdict.robot);
          else if (verdict?.kind === 'takeover' && host.goalPointer.hover)
            host.actions.offerTakeOver({ ...host.goalPointer.hover, yaw: null });
          else if (host.goalPointer.press()) this.goalSlot = slot;
          else if (verdict?.kind === 'refused') input.pulse(slot, 0.3, 60);
        } else if ((slot.source?.hand || slot.mode === 'transient-pointer') && this.#pinchTeleports()) {
          // Point (or look) and pinch: a pinch on nothing to select aims a teleport; letting go lands it.
          this.pinchTeleport = slot;
        }
      } else if (slot === this.pinchTeleport) {
        this.pinchTeleport = null;
        if (this.teleportHit) host.locomotion.teleportTo(this.teleportHit, this.head);
        this.teleportHit = null;
      } else if (slot === this.goalSlot) {
        this.#aimGoal(slot);
        const goal = host.goalPointer.release();
        this.goalSlot = null;
        this.goalViaWim = false;
        if (goal) host.actions.sendGoal(goal);
      }
    }
  }

  #goalPointer() {
    const host = this.host;
    const input = host.xrInput;
    // 4. The goal pointer follows the pointing hand (the one that last selected, else the right one).
    const goalActive = this.#goalActive();
    const pointing = goalActive
      ? (this.goalSlot ?? (this.lastPointer?.source ? this.lastPointer : null) ?? input.side('right'))
      : null;
    // The hand that shows the goal arc shows no straight ray.
    for (const s of input.active()) s.ray.visible = s.pointer && s !== pointing;
    if (goalActive) {
      const slot = pointing;
      if (slot) this.#aimGoal(slot);
      else host.goalPointer.aim(null);
      const arc = slot ? this.lastArc : null;
      host.goalView.setPointer(host.fleet.scene.mapToScene, host.goalPointer.marker, arc, host.goalPointer.verdict);
    } else {
      if (this.goalSlot) [this.goalSlot, this.goalViaWim] = [null, false];
      host.goalPointer.cancel();
      host.goalPointer.aim(null);
      host.goalView.setPointer(host.fleet.scene.mapToScene, null, null);
    }
  }

  /** @param {number} dt s */
  #sticks(dt) {
    const host = this.host;
    const input = host.xrInput;
    const menu = host.menu;
    // 5. Sticks: the right one drives the robot when Teleop is on, else both turn; the left one moves.
    const left = input.side('left');
    const right = input.side('right');
    const [lx, ly] = input.stick(left);
    const [rx, ry] = input.stick(right);
    const rig = host.rig;
    const free = menu.mode === 'free_roam';
    if (menu.tool === 'teleop' && !menu.open) host.actions.driveStick('xr-right', rx, ry);
    else this.#turn(this.snapRight.update(rx));
    let teleportPoints = null;
    if (!menu.open && left) {
      if (menu.smooth && free) {
        const [vx, vz] = smoothVelocity(lx, ly, this.headYaw);
        rig.position.x += vx * dt;
        rig.position.z += vz * dt;
        this.teleport.cancel();
      } else if (free) {
        const gesture = this.teleport.update(ly);
        if (gesture === 'aim') {
          const { origin, direction } = input.ray(left);
          const arc = host.picking.arcToFloor(origin, direction);
          teleportPoints = arc.points;
          this.teleportHit = arc.hit;
        } else if (gesture === 'teleport' && this.teleportHit) {
          host.locomotion.teleportTo(this.teleportHit, this.head);
          this.teleportHit = null;
        }
      }
      if (Math.abs(ly) < 0.5 || !free) this.#turn(this.snapLeft.update(lx));
    } else {
      this.teleport.cancel();
    }
    const hand = this.pinchTeleport;
    if (hand && (!hand.source || !this.#pinchTeleports()))
      this.pinchTeleport = null; // tracking lost, menu opened
    else if (hand && !teleportPoints) {
      const { origin, direction } = input.ray(hand);
      const arc =
        hand.mode === 'transient-pointer'
          ? host.picking.rayToFloor(origin, direction)
          : host.picking.arcToFloor(origin, direction);
      teleportPoints = arc.points;
      this.teleportHit = arc.hit;
    }
    host.teleportView.set(
      teleportPoints,
      teleportPoints ? this.teleportHit && [this.teleportHit.x, this.teleportHit.y, this.teleportHit.z] : null,
    );
  }

  /** @param {number} dt s */
  #comfort(dt) {
    const host = this.host;
    const rig = host.rig;
    // 6. Comfort: the vignette follows the rig's motion (teleports are instantaneous and skip it).
    const moved = rig.position.distanceTo(this.lastRig);
    const turned = Math.abs(rig.rotation.y - this.lastRigYaw);
    const linear = moved < 1 ? moved / Math.max(dt, 1e-3) : 0;
    const angular = turned < 1 ? turned / Math.max(dt, 1e-3) : 0;
    this.vignette = vignetteStrength(this.vignette, linear, angular, dt);
    host.vignette.set(this.vignette);
    this.lastRig.copy(rig.position);
    this.lastRigYaw = rig.rotation.y;
  }

  /** @param {number} dt s */
  #placeTab(dt) {
    const menu = this.host.menu;
    const panel = this.host.menuPanel;
    // 7. The menu tab floats low in front of the operator, following the head lazily.
    const tab = panel.tab;
    tab.visible = !menu.open;
    if (tab.visible) {
      const target = new THREE.Vector3(
        this.head.x - Math.sin(this.headYaw) * 0.55,
        this.head.y - 0.5,
        this.head.z - Math.cos(this.headYaw) * 0.55,
      );
      tab.position.lerp(target, tab.position.lengthSq() === 0 ? 1 : Math.min(1, dt * 3));
      tab.lookAt(this.head);
    }
  }

  /** @type {[number, number, number][] | null} */
  lastArc = null;

  /**
   * What a slot's ray on the overview table means: the full-size map point and what a press would do there.
   * @param {import('./xr_input.js').InputSlot} slot
   */
  #wimAt(slot) {
    const host = this.host;
    if (!this.wimHits.has(slot.index)) return null;
    const { origin, direction } = host.xrInput.ray(slot);
    const at = host.miniature.toTwin(origin, direction, host.fleet.scene.mapToScene);
    if (!at) return null;
    const floor = host.picking.isFloorAt(at.scene);
    const verdict = goalVerdict(
      { point: at.point, floor },
      {
        robots: robotSpots(host.fleet),
        selected: host.menu.selected,
        bounds: host.fleet.bounds,
        holder: host.menu.holder,
      },
    );
    return { ...at, floor, verdict };
  }

  /**
   * A select on the overview table: a robot there is selected; with Goal on, a goal is placed (dragged on the
   * table for its heading); otherwise the operator teleports there, into the full-size twin.
   * @param {import('./xr_input.js').InputSlot} slot
   */
  #wimSelect(slot) {
    const host = this.host;
    const at = this.#wimAt(slot);
    if (!at) return;
    if (at.verdict.kind === 'select') host.actions.selectRobot(at.verdict.robot);
    else if (at.verdict.kind === 'takeover' && this.#goalActive())
      host.actions.offerTakeOver({ ...at.point, yaw: null });
    else if (this.#goalActive()) {
      host.goalPointer.aim(at.point, at.verdict);
      if (host.goalPointer.press()) [this.goalSlot, this.goalViaWim] = [slot, true];
      else host.xrInput.pulse(slot, 0.3, 60);
    } else if (at.floor) {
      host.locomotion.teleportTo(at.scene, this.head);
      host.rig.updateMatrixWorld(true);
      host.miniature.place(host.camera);
    } else host.xrInput.pulse(slot, 0.3, 60);
  }

  /** @param {import('./xr_input.js').InputSlot} slot */
  #aimGoal(slot) {
    const wim = this.#wimAt(slot);
    if (wim || (this.goalViaWim && slot === this.goalSlot)) {
      // On the table (or dragged off it while placing: the last point there holds).
      if (wim) this.host.goalPointer.aim(wim.point, wim.verdict);
      this.lastArc = null;
      return;
    }
    const { origin, direction } = this.host.xrInput.ray(slot);
    const picking = this.host.picking;
    const gaze = slot.mode === 'transient-pointer';
    const { points, surface } = gaze ? picking.rayToFloor(origin, direction) : picking.arcToFloor(origin, direction);
    this.lastArc = points;
    const { point, verdict } = this.host.picking.verdictAt(surface, this.host.menu.selected, this.host.menu.holder);
    this.host.goalPointer.aim(point, verdict);
  }

  /** Whether a hand's pinch on nothing may aim a teleport: free roam, the menu closed, no tool that pinches itself. */
  #pinchTeleports() {
    const menu = this.host.menu;
    return menu.mode === 'free_roam' && !menu.open && menu.tool !== 'teleop' && menu.tool !== 'goal';
  }

  #goalActive() {
    const menu = this.host.menu;
    return menu.tool === 'goal' && menu.mode === 'free_roam' && !menu.open;
  }

  /** Snap turn about the head. @param {number} angle */
  #turn(angle) {
    if (angle !== 0) this.host.locomotion.turnAbout(this.head, angle);
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
    host.camera.getWorldPosition(this.head);
    const forward = host.camera.getWorldDirection(new THREE.Vector3());
    forward.y = 0;
    if (forward.lengthSq() < 1e-6) forward.set(0, 0, -1);
    forward.normalize();
    const mesh = host.menuPanel.mesh;
    mesh.position.copy(this.head).addScaledVector(forward, MENU_DISTANCE);
    mesh.position.y = this.head.y - 0.12;
    mesh.lookAt(this.head.x, mesh.position.y + 0.1, this.head.z);
    // Drawn now (a closed menu is not kept drawn): its buttons are where the first ray after opening meets them.
    host.menuPanel.update(host.menu, null, host.link());
  }

  dispose() {
    this.handInput.dispose();
    this.reticle.dispose();
    this.menuEdges.clear();
    this.estopEdges.clear();
    this.hover.clear();
  }
}

/** @param {Map<number, ButtonEdge>} edges @param {number} index */
function edgeOf(edges, index) {
  let edge = edges.get(index);
  if (!edge) edges.set(index, (edge = new ButtonEdge()));
  return edge;
}

/** Hovering these gives no haptic tick: robots, the twin's floor and the image (a tick per pixel would buzz). */
const QUIET_HOVER = ['pick:', 'insp:floor', 'insp:image', 'wim'];

/** @param {THREE.Object3D | null} object */
function robotOf(object) {
  for (let o = object; o; o = o.parent) if (typeof o.userData.robot === 'string') return `pick:${o.userData.robot}`;
  return null;
}

/** The gaze reticle: a faint ring at the centre of view, and an arc that fills while a dwell runs. */
/** Whether an object is drawn: it and every parent visible. @param {THREE.Object3D} object */
function drawn(object) {
  for (let o = /** @type {THREE.Object3D | null} */ (object); o; o = o.parent) if (!o.visible) return false;
  return true;
}

class Reticle {
  constructor() {
    this.group = new THREE.Group();
    this.group.position.set(0, 0, -1);
    const material = new THREE.MeshBasicMaterial({
      color: 0xffffff,
      transparent: true,
      opacity: 0.5,
      depthTest: false,
    });
    this.ring = new THREE.Mesh(new THREE.RingGeometry(0.008, 0.011, 32), material);
    this.arcMaterial = new THREE.MeshBasicMaterial({ color: 0x3d8bff, depthTest: false });
    this.arc = new THREE.Mesh(new THREE.RingGeometry(0.012, 0.017, 32, 1, Math.PI / 2, 0.001), this.arcMaterial);
    this.ring.renderOrder = this.arc.renderOrder = 20;
    // Only the headset's eyes see it (three.js's XR cameras enable layers 1 and 2; the desktop camera has 0 alone).
    for (const mesh of [this.ring, this.arc]) {
      mesh.layers.disableAll();
      mesh.layers.enable(1);
      mesh.layers.enable(2);
    }
    this.group.add(this.ring, this.arc);
    this.fill = 0;
  }

  /** @param {number} fill 0..1 */
  setFill(fill) {
    const rounded = Math.round(fill * 24) / 24; // a new ring at most 24 times a dwell
    if (rounded === this.fill) return;
    this.fill = rounded;
    this.arc.geometry.dispose();
    this.arc.geometry = new THREE.RingGeometry(
      0.012,
      0.017,
      32,
      1,
      Math.PI / 2,
      Math.max(0.001, rounded * Math.PI * 2),
    );
    this.arc.visible = rounded > 0;
  }

  dispose() {
    this.group.removeFromParent();
    this.ring.geometry.dispose();
    this.arc.geometry.dispose();
    /** @type {THREE.Material} */ (this.ring.material).dispose();
    this.arcMaterial.dispose();
  }
}
