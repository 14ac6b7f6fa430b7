// @ts-check
/**
 * What hands add beyond WebXR's select events (which already work wherever a controller's trigger does: a pinch on
 * the menu, a robot, a goal, a target): the pinch-drag joystick that drives the selected robot while Teleop is on,
 * its release the deadman (zero at once); the two wrist buttons that appear side by side over a palm turned up, a red
 * E-STOP and the blue menu button, that the other hand's index presses; and the fist held
 * closed, E-STOP with nothing to aim at (a red ring fills around the fist while it is held). Read each XR frame from
 * three.js's hand joints; the decisions are gestures.js's (node-tested against recorded hand poses).
 */
import * as THREE from 'three';
import { FistHold, PalmUp, PinchDetector, PinchJoystick, distance, fingerReach } from '../gestures.js';
import { ALARM_RED } from './estop_view.js';

/** Where the wrist buttons float over a palm turned up: this far over it (along its normal), this far from the wrist
 * towards the fingers, and this far to either side across the hand (the E-STOP on one side, the menu on the other):
 * side by side as the eyes see them, 8 cm apart, so that an index tip (PRESS_M) presses one or the other (m). */
const BUTTON_LIFT_M = 0.05;
const BUTTON_FORWARD_M = 0.03;
const BUTTON_SIDE_M = 0.04;
/** An index tip this close to a button's centre presses it (m). */
const PRESS_M = 0.03;
/** The fist's ring: its radius, and how far from the fist towards the eyes it hangs (m). */
const RING_RADIUS_M = 0.055;
const RING_TOWARDS_EYES_M = 0.06;

/**
 * @typedef {{xrInput: import('./xr_input.js').XRInput, menu: import('../menu_state.js').MenuState,
 *   actions: import('../app.js').OperatorActions, camera: THREE.Camera}} HandHost
 * @typedef {{pinch: PinchDetector, palm: PalmUp, stick: PinchJoystick, fist: FistHold, driving: string | null,
 *   pressed: string | null}} HandState `pressed`: the wrist button the other index touches (one press per touch)
 */

/** @param {THREE.Object3D | undefined} joint @returns {[number, number, number] | null} */
function worldOf(joint) {
  if (!joint || !joint.visible) return null;
  const v = joint.getWorldPosition(new THREE.Vector3());
  return [v.x, v.y, v.z];
}

/** A round wrist button with a word on it. @param {string} colour @param {string} word @param {number} radius */
function roundButton(colour, word, radius) {
  const canvas = document.createElement('canvas');
  canvas.width = canvas.height = 128;
  const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
  ctx.beginPath();
  ctx.arc(64, 64, 62, 0, Math.PI * 2);
  ctx.fillStyle = '#ffffff';
  ctx.fill();
  ctx.beginPath();
  ctx.arc(64, 64, 56, 0, Math.PI * 2);
  ctx.fillStyle = colour;
  ctx.fill();
  ctx.fillStyle = '#ffffff';
  ctx.textAlign = 'center';
  ctx.textBaseline = 'middle';
  ctx.font = `800 ${word.length > 2 ? 30 : 56}px Inter, system-ui, sans-serif`;
  ctx.fillText(word, 64, 67);
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  const mesh = new THREE.Mesh(
    new THREE.CircleGeometry(radius, 32),
    new THREE.MeshBasicMaterial({ map: texture, side: THREE.DoubleSide, depthTest: false, transparent: true }),
  );
  mesh.renderOrder = 10;
  mesh.visible = false;
  mesh.raycast = () => {}; // pressed by a fingertip, not by a ray
  return mesh;
}

export class HandInput {
  /** @param {HandHost} host @param {THREE.Object3D} scene */
  constructor(host, scene) {
    this.host = host;
    /** @type {Map<number, HandState>} */
    this.hands = new Map();
    /** The blue menu button and the red E-STOP over a palm turned up. */
    this.button = roundButton('#3d8bff', '☰', 0.018);
    this.button.name = 'wrist-menu-button';
    this.estopButton = roundButton(ALARM_RED, 'STOP', 0.022);
    this.estopButton.name = 'wrist-estop-button';
    scene.add(this.button, this.estopButton);
    /** The fist's ring: a faint circle, and the arc that fills while the fist is held. */
    this.ring = new THREE.Group();
    this.ring.name = 'fist-estop-ring';
    this.ring.visible = false;
    this.ringBase = new THREE.Mesh(
      new THREE.RingGeometry(RING_RADIUS_M * 0.8, RING_RADIUS_M, 48),
      new THREE.MeshBasicMaterial({
        color: ALARM_RED,
        transparent: true,
        opacity: 0.35,
        depthTest: false,
        side: THREE.DoubleSide,
      }),
    );
    this.arcMaterial = new THREE.MeshBasicMaterial({ color: ALARM_RED, depthTest: false, side: THREE.DoubleSide });
    this.arc = new THREE.Mesh(this.#arcGeometry(0), this.arcMaterial);
    this.ringBase.renderOrder = this.arc.renderOrder = 11;
    this.ring.add(this.ringBase, this.arc);
    scene.add(this.ring);
    this.ringFill = 0;
    /** The hand whose palm shows the buttons (its slot index), or null. @type {number | null} */
    this.buttonHand = null;
    /** What the state snapshot shows. */
    this.stats = { pinches: 0, drives: 0, releases: 0, menuPresses: 0, estopPresses: 0, fistStops: 0 };
    /**
     * Each tracked hand's index fingertip this frame (world), by handedness: where a press comes from.
     * @type {Record<string, number[]>}
     */
    this.tips = {};
    /** Each tracked hand's fist: how far through the hold (0..1), by handedness. @type {Record<string, number>} */
    this.fists = {};
  }

  /** One XR frame. @param {number} headYaw the head's yaw (rad) @param {number} now ms */
  update(headYaw, now) {
    const { xrInput, menu, actions } = this.host;
    const hands = xrInput.active().filter((slot) => slot.source?.hand);
    const seen = new Set();
    this.tips = {};
    this.fists = {};
    /** @type {{index: number, tip: [number, number, number]}[]} */
    const tips = [];
    /** @type {{slot: number, estop: THREE.Vector3, menu: THREE.Vector3} | null} */
    let palm = null;
    /** @type {{fill: number, at: THREE.Vector3} | null} */
    let fistRing = null;
    for (const slot of hands) {
      seen.add(slot.index);
      let state = this.hands.get(slot.index);
      if (!state)
        this.hands.set(
          slot.index,
          (state = {
            pinch: new PinchDetector(),
            palm: new PalmUp(),
            stick: new PinchJoystick(),
            fist: new FistHold(),
            driving: null,
            pressed: null,
          }),
        );
      const joints = /** @type {Record<string, THREE.Object3D>} */ (/** @type {any} */ (slot.hand).joints ?? {});
      const thumb = worldOf(joints['thumb-tip']);
      const index = worldOf(joints['index-finger-tip']);
      const wrist = joints.wrist;
      const side = slot.source?.handedness ?? String(slot.index);
      if (!thumb || !index || !wrist) {
        state.fist.reset();
        continue;
      }
      tips.push({ index: slot.index, tip: index });
      this.tips[side] = index;
      // A fist held closed: E-STOP, once per closing. A closed hand drives nothing meanwhile (its thumb may well
      // touch its index: that is no pinch to drive with).
      const fist = state.fist.update(
        fingerReach((name) => worldOf(joints[name])),
        now,
      );
      this.fists[side] = fist.closed ? (state.fist.fired ? 1 : fist.fill) : 0;
      if (fist.fire) {
        this.stats.fistStops++;
        actions.pressMenu('estop');
      }
      if (fist.closed && !state.fist.fired && (!fistRing || fist.fill > fistRing.fill)) {
        const knuckle = joints['middle-finger-phalanx-proximal'];
        const at = wrist.getWorldPosition(new THREE.Vector3());
        if (knuckle) at.add(knuckle.getWorldPosition(new THREE.Vector3())).multiplyScalar(0.5);
        fistRing = { fill: fist.fill, at };
      }
      const { pinched, changed } = state.pinch.update(fist.closed ? Infinity : distance(thumb, index));
      const source = `hand-${side}`;
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
      // The palm turned up: its wrist buttons, side by side over it (E-STOP and the menu).
      const turn = wrist.getWorldQuaternion(new THREE.Quaternion());
      const up = new THREE.Vector3(0, -1, 0).applyQuaternion(turn);
      if (state.palm.update([up.x, up.y, up.z]) && !fist.closed && palm === null) {
        const forward = new THREE.Vector3(0, 0, -1).applyQuaternion(turn);
        const across = new THREE.Vector3(1, 0, 0).applyQuaternion(turn);
        const base = wrist
          .getWorldPosition(new THREE.Vector3())
          .addScaledVector(up, BUTTON_LIFT_M)
          .addScaledVector(forward, BUTTON_FORWARD_M);
        palm = {
          slot: slot.index,
          estop: base.clone().addScaledVector(across, BUTTON_SIDE_M),
          menu: base.clone().addScaledVector(across, -BUTTON_SIDE_M),
        };
      }
    }
    // Hands that went away (tracking lost, controllers picked up) stop what they drove.
    for (const [index, state] of this.hands) {
      if (!seen.has(index)) {
        if (state.driving) this.#release(state);
        this.hands.delete(index);
      }
    }
    this.#buttons(palm, tips);
    this.#ring(fistRing);
  }

  /**
   * Show the wrist buttons over the palm turned up, and press the one the other hand's index touches (once a touch).
   * @param {{slot: number, estop: THREE.Vector3, menu: THREE.Vector3} | null} palm
   * @param {{index: number, tip: [number, number, number]}[]} tips
   */
  #buttons(palm, tips) {
    this.buttonHand = palm?.slot ?? null;
    this.button.visible = this.estopButton.visible = palm !== null;
    for (const [index, state] of this.hands) if (index !== palm?.slot) state.pressed = null;
    if (!palm) return;
    const eyes = this.host.camera.getWorldPosition(new THREE.Vector3());
    this.estopButton.position.copy(palm.estop);
    this.button.position.copy(palm.menu);
    this.estopButton.lookAt(eyes);
    this.button.lookAt(eyes);
    const other = tips.find((t) => t.index !== palm.slot);
    const state = this.hands.get(palm.slot);
    if (!state) return;
    /** @type {string | null} */
    let touched = null;
    if (other) {
      const toEstop = distance(other.tip, [palm.estop.x, palm.estop.y, palm.estop.z]);
      const toMenu = distance(other.tip, [palm.menu.x, palm.menu.y, palm.menu.z]);
      if (Math.min(toEstop, toMenu) < PRESS_M) touched = toEstop <= toMenu ? 'estop' : 'menu';
    }
    if (touched && touched !== state.pressed) {
      if (touched === 'estop') {
        this.stats.estopPresses++;
        this.host.actions.pressMenu('estop');
      } else {
        this.stats.menuPresses++;
        this.host.actions.toggleMenu();
      }
    }
    state.pressed = touched;
  }

  /**
   * The fist's ring around the fist held, filling until it stops the fleet.
   * @param {{fill: number, at: THREE.Vector3} | null} fist
   */
  #ring(fist) {
    this.ring.visible = fist !== null;
    if (!fist) return;
    const eyes = this.host.camera.getWorldPosition(new THREE.Vector3());
    this.ring.position.copy(fist.at).addScaledVector(eyes.clone().sub(fist.at).normalize(), RING_TOWARDS_EYES_M);
    this.ring.lookAt(eyes);
    const rounded = Math.round(fist.fill * 24) / 24; // a new arc at most 24 times a hold
    if (rounded !== this.ringFill) {
      this.ringFill = rounded;
      this.arc.geometry.dispose();
      this.arc.geometry = this.#arcGeometry(rounded);
    }
  }

  /** The filled part of the ring, clockwise from the top. @param {number} fill 0..1 */
  #arcGeometry(fill) {
    return new THREE.RingGeometry(
      RING_RADIUS_M * 0.8,
      RING_RADIUS_M,
      48,
      1,
      Math.PI / 2,
      -Math.max(0.001, fill * Math.PI * 2),
    );
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
      estopButton: this.estopButton.visible ? this.estopButton.position.toArray() : null,
      fists: this.fists,
      ring: this.ring.visible ? this.ringFill : null,
      tips: this.tips,
      driving: [...this.hands.values()].some((h) => h.driving !== null),
    };
  }

  dispose() {
    for (const mesh of [this.button, this.estopButton]) {
      mesh.removeFromParent();
      mesh.geometry.dispose();
      const material = /** @type {THREE.MeshBasicMaterial} */ (mesh.material);
      material.map?.dispose();
      material.dispose();
    }
    this.ring.removeFromParent();
    this.ringBase.geometry.dispose();
    /** @type {THREE.Material} */ (this.ringBase.material).dispose();
    this.arc.geometry.dispose();
    this.arcMaterial.dispose();
  }
}
