// @ts-check
/**
 * What hands add beyond WebXR's select events (which already work wherever a controller's trigger does: a pinch on
 * the menu, a robot, a goal, a target): the pinch-drag joystick that drives the selected robot while Teleop is on,
 * its release the deadman (zero at once), and the wrist button that appears when a palm turns up and that the other
 * hand's index presses to open the menu. Read each XR frame from three.js's hand joints; the decisions are
 * gestures.js's (node-tested against recorded hand poses).
 */
import * as THREE from 'three';
import { PalmUp, PinchDetector, PinchJoystick, distance } from '../gestures.js';

/** How far above the wrist (along the palm's normal) the button floats, and how close an index tip presses it (m). */
const BUTTON_LIFT_M = 0.05;
const PRESS_M = 0.03;

/**
 * @typedef {{xrInput: import('./xr_input.js').XRInput, menu: import('../menu_state.js').MenuState,
 *   actions: import('../app.js').OperatorActions}} HandHost
 */

/** @param {THREE.Object3D | undefined} joint @returns {[number, number, number] | null} */
function worldOf(joint) {
  if (!joint || !joint.visible) return null;
  const v = joint.getWorldPosition(new THREE.Vector3());
  return [v.x, v.y, v.z];
}

export class HandInput {
  /** @param {HandHost} host @param {THREE.Object3D} scene */
  constructor(host, scene) {
    this.host = host;
    /** @type {Map<number, {pinch: PinchDetector, palm: PalmUp, stick: PinchJoystick, driving: string | null, pressed: boolean}>} */
    this.hands = new Map();
    this.button = new THREE.Mesh(
      new THREE.CircleGeometry(0.018, 24),
      new THREE.MeshBasicMaterial({ color: 0x3d8bff, side: THREE.DoubleSide, depthTest: false, transparent: true, opacity: 0.95 }),
    );
    this.button.renderOrder = 10;
    this.button.visible = false;
    scene.add(this.button);
    /** The hand whose palm shows the button (its slot index), or null. @type {number | null} */
    this.buttonHand = null;
    /** What the state snapshot shows. */
    this.stats = { pinches: 0, drives: 0, releases: 0, menuPresses: 0 };
    /** Each tracked hand's index fingertip this frame (world), by handedness: where a press comes from. @type {Record<string, number[]>} */
    this.tips = {};
  }

  /** One XR frame. @param {number} headYaw the head's yaw (rad) */
  update(headYaw) {
    const { xrInput, menu, actions } = this.host;
    const hands = xrInput.active().filter((slot) => slot.source?.hand);
    const seen = new Set();
    this.tips = {};
    /** @type {{index: number, tip: [number, number, number]}[]} */
    const tips = [];
    let palmSlot = null;
    let palmAt = null;
    for (const slot of hands) {
      seen.add(slot.index);
      let state = this.hands.get(slot.index);
      if (!state) this.hands.set(slot.index, (state = { pinch: new PinchDetector(), palm: new PalmUp(), stick: new PinchJoystick(), driving: null, pressed: false }));
      const joints = /** @type {Record<string, THREE.Object3D>} */ (/** @type {any} */ (slot.hand).joints ?? {});
      const thumb = worldOf(joints['thumb-tip']);
      const index = worldOf(joints['index-finger-tip']);
      const wrist = joints.wrist;
      if (!thumb || !index || !wrist) continue;
      tips.push({ index: slot.index, tip: index });
      this.tips[slot.source?.handedness ?? String(slot.index)] = index;
      const { pinched, changed } = state.pinch.update(distance(thumb, index));
      const source = `hand-${slot.source?.handedness ?? slot.index}`;
      // Teleop by pinch-drag: the pinch's place is the stick's centre; its release is the deadman.
      const canDrive = menu.tool === 'teleop' && menu.selected !== null;
      if (changed && pinched) {
        this.stats.pinches++;
        if (canDrive) {
          state.stick.start(index);
          state.driving = source;
        }
      }
      if (state.driving && (!pinched || !canDrive)) this.#release(state);
      if (state.driving) {
        const { x, y } = state.stick.axes(index, headYaw);
        actions.driveStick(state.driving, x, y);
        this.stats.drives++;
      }
      // The palm turned up: its wrist button.
      const up = new THREE.Vector3(0, -1, 0).applyQuaternion(wrist.getWorldQuaternion(new THREE.Quaternion()));
      if (state.palm.update([up.x, up.y, up.z]) && palmSlot === null) {
        palmSlot = slot.index;
        palmAt = wrist.getWorldPosition(new THREE.Vector3()).addScaledVector(up, BUTTON_LIFT_M);
      }
    }
    // Hands that went away (tracking lost, controllers picked up) stop what they drove.
    for (const [index, state] of this.hands) {
      if (!seen.has(index)) {
        if (state.driving) this.#release(state);
        this.hands.delete(index);
      }
    }
    this.buttonHand = palmSlot;
    this.button.visible = palmAt !== null;
    if (palmAt) {
      this.button.position.copy(palmAt);
      const other = tips.find((t) => t.index !== palmSlot);
      const state = palmSlot !== null ? this.hands.get(palmSlot) : undefined;
      const touching = Boolean(other && distance(other.tip, [palmAt.x, palmAt.y, palmAt.z]) < PRESS_M);
      if (state && touching && !state.pressed) {
        this.stats.menuPresses++;
        actions.toggleMenu();
      }
      if (state) state.pressed = touching;
    }
  }

  /** @param {{stick: PinchJoystick, driving: string | null}} state */
  #release(state) {
    if (state.driving) this.host.actions.driveStick(state.driving, 0, 0);
    state.stick.release();
    state.driving = null;
    this.stats.releases++;
  }

  /** What the state snapshot shows (`s.hands`). */
  state() {
    return {
      ...this.stats,
      wristButton: this.button.visible,
      button: this.button.visible ? this.button.position.toArray() : null,
      tips: this.tips,
      driving: [...this.hands.values()].some((h) => h.driving !== null),
    };
  }

  dispose() {
    this.button.removeFromParent();
    this.button.geometry.dispose();
    /** @type {THREE.Material} */ (this.button.material).dispose();
  }
}
