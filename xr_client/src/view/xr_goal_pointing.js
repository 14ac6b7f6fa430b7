// @ts-check
/**
 * Pointing at the map in VR: the goal pointer on the pointing hand (its arc to the floor, the eyes' straight ray;
 * press for the position, drag for the heading, release to send) and the overview table (its cursor, and a press on
 * it: a robot selected, a goal placed, or a teleport into the full-size twin).
 */
import { goalVerdict, robotSpots } from '../goal_verdict.js';

/**
 * What goal pointing reads and drives.
 * @typedef {{xrInput: import('./xr_input.js').XRInput, camera: import('three').PerspectiveCamera,
 *   rig: import('three').Group, menu: import('../menu_state.js').MenuState,
 *   goalPointer: import('../goal_pointer.js').GoalPointer, goalView: import('./goal_view.js').GoalView,
 *   fleet: import('../fleet_model.js').FleetModel, picking: import('./picking.js').Picking,
 *   locomotion: import('./xr_session.js').XRSessionController, actions: import('../app.js').OperatorActions,
 *   miniature: import('./miniature_view.js').MiniatureView}} GoalHost
 * @typedef {import('./xr_input.js').InputSlot} InputSlot
 */

export class XRGoalPointing {
  /** @type {[number, number, number][] | null} */
  lastArc = null;

  /** @param {GoalHost} host @param {import('./xr_motion.js').Head} head */
  constructor(host, head) {
    this.host = host;
    this.head = head;
    /** @type {InputSlot | null} the slot holding a goal press */
    this.goalSlot = null;
    /** @type {InputSlot | null} */
    this.lastPointer = null;
    /** Each slot's ray on the overview table this frame. @type {Map<number, import('three').Intersection>} */
    this.wimHits = new Map();
    /** The goal being placed was pressed on the overview table: it is dragged there too. */
    this.goalViaWim = false;
    /**
     * Where the pointing hand meets the table, and what a press there would do (the table's cursor).
     * @type {{point: {x: number, y: number}, verdict: import('../goal_verdict.js').GoalVerdict} | null}
     */
    this.wimCursor = null;
  }

  /** Whether the goal tool points now: Goal on, in free roam, the menu closed. */
  active() {
    const menu = this.host.menu;
    return menu.tool === 'goal' && menu.mode === 'free_roam' && !menu.open;
  }

  /** The table's cursor, from the rays that met the table this frame. */
  updateCursor() {
    const input = this.host.xrInput;
    const onTable = input.active().find((slot) => this.wimHits.has(slot.index));
    const at = onTable ? this.#wimAt(onTable) : null;
    this.wimCursor = at ? { point: at.point, verdict: at.verdict } : null;
  }

  update() {
    const host = this.host;
    const input = host.xrInput;
    // 4. The goal pointer follows the pointing hand (the one that last selected, else the right one).
    const goalActive = this.active();
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

  /**
   * A select on nothing else while the goal tool points: the arc on a robot selects it (it never becomes a goal into
   * that robot), on a held robot offers a take-over, else it presses the goal's position; a refusal pulses.
   * @param {InputSlot} slot
   */
  press(slot) {
    const host = this.host;
    this.#aimGoal(slot);
    const verdict = host.goalPointer.verdict;
    if (verdict?.kind === 'select') host.actions.selectRobot(verdict.robot);
    else if (verdict?.kind === 'takeover' && host.goalPointer.hover)
      host.actions.offerTakeOver({ ...host.goalPointer.hover, yaw: null });
    else if (host.goalPointer.press()) this.goalSlot = slot;
    else if (verdict?.kind === 'refused') host.xrInput.pulse(slot, 0.3, 60);
  }

  /** The slot holding the goal press lets go: the goal goes out. @param {InputSlot} slot */
  release(slot) {
    const host = this.host;
    this.#aimGoal(slot);
    const goal = host.goalPointer.release();
    this.goalSlot = null;
    this.goalViaWim = false;
    if (goal) host.actions.sendGoal(goal);
  }

  /**
   * What a slot's ray on the overview table means: the full-size map point and what a press there would do.
   * @param {InputSlot} slot
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
   * @param {InputSlot} slot
   */
  wimSelect(slot) {
    const host = this.host;
    const at = this.#wimAt(slot);
    if (!at) return;
    if (at.verdict.kind === 'select') host.actions.selectRobot(at.verdict.robot);
    else if (at.verdict.kind === 'takeover' && this.active()) host.actions.offerTakeOver({ ...at.point, yaw: null });
    else if (this.active()) {
      host.goalPointer.aim(at.point, at.verdict);
      if (host.goalPointer.press()) [this.goalSlot, this.goalViaWim] = [slot, true];
      else host.xrInput.pulse(slot, 0.3, 60);
    } else if (at.floor) {
      host.locomotion.teleportTo(at.scene, this.head.position);
      host.rig.updateMatrixWorld(true);
      host.miniature.place(host.camera);
    } else host.xrInput.pulse(slot, 0.3, 60);
  }

  /** @param {InputSlot} slot */
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
}
