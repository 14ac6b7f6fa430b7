// @ts-check
/**
 * The XR input sources as the rest of the client sees them: up to four slots (two controllers or hands,
 * plus transient pointers such as Vision Pro's gaze-and-pinch), each with its target ray, gamepad, a
 * visible pointer ray, a controller or hand model (served locally from @webxr-input-profiles/assets), and
 * the select events received since the last frame. Listeners are added here and removed in dispose().
 */
import * as THREE from 'three';
import { XRControllerModelFactory } from 'three/addons/webxr/XRControllerModelFactory.js';
import { XRHandModelFactory } from 'three/addons/webxr/XRHandModelFactory.js';

export const PROFILES_PATH = '/node_modules/@webxr-input-profiles/assets/dist/profiles';
const SLOTS = 4;

/**
 * @typedef {{index: number, controller: THREE.XRTargetRaySpace, grip: THREE.XRGripSpace, hand: THREE.XRHandSpace,
 *   ray: THREE.Line, cursor: THREE.Mesh, source: XRInputSource | null, events: ('selectstart' | 'selectend')[],
 *   selecting: boolean, squeezing: boolean, pointer: boolean, mode: XRTargetRayMode | null}} InputSlot
 */

export class XRInput {
  /**
   * @param {THREE.WebGLRenderer} renderer
   * @param {THREE.Object3D} rig the operator's rig: controllers move with it
   * @param {THREE.Object3D} scene where the cursors live (world coordinates)
   */
  constructor(renderer, rig, scene) {
    this.controllerModels = new XRControllerModelFactory().setPath(PROFILES_PATH);
    this.handModels = new XRHandModelFactory().setPath(`${PROFILES_PATH}/generic-hand/`);
    this.rayGeometry = new THREE.BufferGeometry().setFromPoints([
      new THREE.Vector3(0, 0, 0),
      new THREE.Vector3(0, 0, -1),
    ]);
    this.rayMaterial = new THREE.LineBasicMaterial({ color: '#ffffff', transparent: true, opacity: 0.6 });
    this.cursorGeometry = new THREE.SphereGeometry(0.012, 12, 8);
    this.cursorMaterial = new THREE.MeshBasicMaterial({ color: '#ffffff', depthTest: false });
    /** @type {InputSlot[]} */
    this.slots = [];
    /** The haptic pulses handed to a device's actuator: how many, and the last (the state snapshot shows it). */
    this.felt = { count: 0, hand: '', intensity: 0, ms: 0 };
    /** @type {(() => void)[]} */
    this.unlisten = [];
    for (let index = 0; index < SLOTS; index++) {
      const controller = renderer.xr.getController(index);
      const grip = renderer.xr.getControllerGrip(index);
      const hand = renderer.xr.getHand(index);
      grip.add(this.controllerModels.createControllerModel(grip));
      hand.add(this.handModels.createHandModel(hand, 'mesh'));
      const ray = new THREE.Line(this.rayGeometry, this.rayMaterial);
      ray.raycast = () => {};
      ray.visible = false;
      controller.add(ray);
      const cursor = new THREE.Mesh(this.cursorGeometry, this.cursorMaterial);
      cursor.renderOrder = 40;
      cursor.visible = false;
      cursor.raycast = () => {};
      rig.add(controller, grip, hand);
      scene.add(cursor);
      /** @type {InputSlot} */
      const slot = {
        index,
        controller,
        grip,
        hand,
        ray,
        cursor,
        source: null,
        events: [],
        selecting: false,
        squeezing: false, // the grip button held: takes a robot's arm near the hand (xr_arm_grab.js)
        pointer: false,
        mode: null,
      };
      this.slots.push(slot);
      this.#listen(controller, 'connected', (/** @type {any} */ event) => {
        slot.source = event.data;
        // Kept after a disconnect: a transient pointer's selectend is handled after it went, as what it was.
        slot.mode = event.data.targetRayMode;
        // Transient pointers (gaze-and-pinch) draw no ray: the operator looks where they point.
        slot.pointer = event.data.targetRayMode === 'tracked-pointer' || Boolean(event.data.hand);
        ray.visible = slot.pointer;
      });
      this.#listen(controller, 'disconnected', () => {
        if (slot.selecting) slot.events.push('selectend');
        slot.squeezing = false;
        slot.source = null;
        slot.pointer = false;
        ray.visible = false;
        cursor.visible = false;
      });
      this.#listen(controller, 'selectstart', () => {
        slot.selecting = true;
        slot.events.push('selectstart');
      });
      this.#listen(controller, 'selectend', () => {
        slot.selecting = false;
        slot.events.push('selectend');
      });
      this.#listen(controller, 'squeezestart', () => (slot.squeezing = true));
      this.#listen(controller, 'squeezeend', () => (slot.squeezing = false));
    }
  }

  /**
   * @param {THREE.Object3D} target @param {string} type @param {(event: any) => void} listener
   */
  #listen(target, type, listener) {
    const t = /** @type {THREE.EventDispatcher<any>} */ (target);
    t.addEventListener(type, listener);
    this.unlisten.push(() => t.removeEventListener(type, listener));
  }

  /** Connected slots. */
  active() {
    return this.slots.filter((s) => s.source !== null);
  }

  /** The controller (or hand) of one side, if connected. @param {'left' | 'right'} handedness */
  side(handedness) {
    return (
      this.slots.find((s) => s.source?.handedness === handedness && s.source.targetRayMode === 'tracked-pointer') ??
      null
    );
  }

  /**
   * What the wrist panel (and its E-STOP) ride on, on one side: a controller's grip, or a tracked hand's wrist joint
   * (its +Y out of the back of the hand, -Z towards the fingers: a hand held palm down carries the panel as a
   * controller's grip does). three.js moves and shows its grip group for controllers only: with hands the panel
   * stayed where the controller had been, unseen, and a pinch there still pressed its E-STOP. Null with nothing on
   * that side (or a hand whose wrist is not tracked yet).
   * @param {'left' | 'right'} handedness @returns {{carrier: THREE.Object3D, hand: boolean} | null}
   */
  wrist(handedness) {
    const slot = this.side(handedness);
    if (!slot?.source) return null;
    if (!slot.source.hand) return { carrier: slot.grip, hand: false };
    const joint = slot.hand.joints.wrist;
    return joint ? { carrier: joint, hand: true } : null;
  }

  /** The slot's ray in world space. @param {InputSlot} slot */
  ray(slot) {
    // Its world matrix as of this frame's pose, not the last render's: a transient pointer (gaze-and-pinch) is born
    // with its selectstart, and the frame that brings both would otherwise ray from where nothing was.
    slot.controller.updateWorldMatrix(true, false);
    const origin = new THREE.Vector3().setFromMatrixPosition(slot.controller.matrixWorld);
    const direction = new THREE.Vector3(0, 0, -1).transformDirection(slot.controller.matrixWorld);
    return { origin, direction };
  }

  /** The thumbstick (xr-standard axes 2, 3; a touchpad-only controller's 0, 1). @param {InputSlot | null} slot */
  stick(slot) {
    const axes = slot?.source?.gamepad?.axes;
    if (!axes) return [0, 0];
    return axes.length >= 4 ? [axes[2], axes[3]] : [axes[0] ?? 0, axes[1] ?? 0];
  }

  /** @param {InputSlot | null} slot @param {number} index xr-standard button index */
  pressed(slot, index) {
    return Boolean(slot?.source?.gamepad?.buttons[index]?.pressed);
  }

  /** How far the trigger (xr-standard button 0) is pulled: 0 at rest .. 1. @param {InputSlot | null} slot */
  trigger(slot) {
    return Number(slot?.source?.gamepad?.buttons[0]?.value ?? 0);
  }

  /** Select events since the last call. @param {InputSlot} slot */
  takeEvents(slot) {
    const events = slot.events;
    slot.events = [];
    return events;
  }

  /**
   * A haptic tick or pulse, where the device has one.
   * @param {InputSlot | null} slot @param {number} intensity 0..1 @param {number} ms
   */
  pulse(slot, intensity, ms) {
    const gamepad = /** @type {any} */ (slot?.source?.gamepad);
    const actuator = gamepad?.hapticActuators?.[0] ?? gamepad?.vibrationActuator;
    try {
      if (actuator?.pulse) actuator.pulse(intensity, ms);
      else
        actuator?.playEffect?.('dual-rumble', { duration: ms, strongMagnitude: intensity, weakMagnitude: intensity });
      if (actuator) this.felt = { count: this.felt.count + 1, hand: slot?.source?.handedness ?? '', intensity, ms };
    } catch {
      // Haptics are a courtesy: a device without them is not an error.
    }
  }

  /**
   * Show the ray up to a hit (or 1.5 m) and the cursor on it.
   * @param {InputSlot} slot @param {THREE.Vector3 | null} hit @param {number} distance
   */
  showHit(slot, hit, distance) {
    slot.ray.scale.z = hit ? distance : 1.5;
    slot.cursor.visible = hit !== null && slot.ray.visible;
    if (hit) slot.cursor.position.copy(hit);
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
    for (const slot of this.slots) {
      slot.controller.removeFromParent();
      slot.grip.removeFromParent();
      slot.hand.removeFromParent();
      slot.cursor.removeFromParent();
    }
    this.rayGeometry.dispose();
    this.rayMaterial.dispose();
    this.cursorGeometry.dispose();
    this.cursorMaterial.dispose();
  }
}
