// @ts-check
/**
 * The hand on the selected robot's arm, in VR: a squeeze (grip button) with the hand near the arm's gripper takes
 * it, the gripper then follows the hand (arm_grab.js; half its motion, or all of it with the menu's **Hand 1:1**) as
 * arm twists at the teleop rate (the station's jogArm: arm_jog.js), and letting go, or the hand leaving tracking,
 * stops it. While held, the hand's trigger is the gripper (its travel from open to closed, `GripperTrigger`) and
 * selects nothing else. A tick of haptics says the arm was taken; a motion the relay refuses (a joint limit, the
 * workspace's edge, the arm reaching into its base) pulses the holding hand and shows why beside the gripper. The
 * camera on the gripper, if the arm has one, is shown beside it while it is held (view/gripper_camera.js).
 * The hand's position and turn are read in the robot's body (RobotView.body), so the robot's pose, heading and the
 * twin's scale are in them; the body's glTF frame (y up, z back) is turned into the arm's base link (x forward, y left,
 * z up). The tip's pointing is its last link in the joints' skeleton (from the wrist to the tip).
 */
import * as THREE from 'three';
import { ArmGrab, GripperTrigger, HAND_SCALE } from '../arm_grab.js';
import { GripperCamera } from './gripper_camera.js';
import { LabelSprite } from './label_sprite.js';

const world = new THREE.Vector3();
const turned = new THREE.Quaternion();
const bodyTurn = new THREE.Quaternion();
/** The body's glTF frame (y up, z back) to the arm's base link (x forward, y left, z up): a quarter turn about x. */
const TO_BASE = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(1, 0, 0), Math.PI / 2);
const FROM_BASE = TO_BASE.clone().invert();
/** The refusal's line hangs this far over the gripper (m). */
const LABEL_ABOVE = 0.07;

/**
 * @typedef {{input: import('./xr_input.js').XRInput, menu: import('../menu_state.js').MenuState,
 *   robotViews: Map<string, import('./robot_view.js').RobotView>,
 *   actions: import('../app.js').OperatorActions, world: THREE.Object3D, camera: THREE.Camera,
 *   stream: (robot: string, camera: string, fps: number) => void,
 *   armCamera: (robot: string) => import('../protocol.js').CameraDescription | null}} ArmGrabHost `armCamera`: the
 *   robot's camera on its arm (hello's `on_arm`), `stream` asks the relay for a camera's pictures
 */

export class XRArmGrab {
  /** @param {ArmGrabHost} host */
  constructor(host) {
    this.host = host;
    this.grab = new ArmGrab();
    this.trigger = new GripperTrigger();
    /** Whether each slot squeezed at the last frame (a squeeze starts on the frame it is first seen). */
    this.squeezed = [false, false, false, false];
    /** Whether the last frame asked the arm to move (a release sends the one zero). */
    this.moving = false;
    /** Why the arm's last motion was refused, beside its gripper while it is news. */
    this.label = new LabelSprite({ width: 768, height: 96, worldHeight: 0.045, onTop: true });
    this.label.sprite.visible = false;
    host.world.add(this.label.sprite);
    /** The gripper's own camera, beside it while the arm is held. */
    this.gripperCamera = new GripperCamera({ world: host.world, camera: host.camera, stream: host.stream });
  }

  /**
   * Once a frame in VR, before the rays' selects (the holding hand's trigger is the gripper's).
   * @param {import('../arm_state.js').ArmState} arms the arms' joints and refusals @param {number} now ms
   */
  update(arms, now) {
    const { input, menu, robotViews, actions } = this.host;
    const robot = menu.selected;
    const joints = robot ? arms.joints.get(robot) : undefined;
    const body = robot ? robotViews.get(robot)?.body : undefined;
    const tip = /** @type {[number, number, number] | undefined} */ (joints?.points.at(-1));
    for (const slot of input.slots) {
      const hand = body && tip && slot.source ? this.#hand(slot, body) : null;
      const began = slot.squeezing && !this.squeezed[slot.index];
      this.squeezed[slot.index] = slot.squeezing;
      const pointing = hand && began && joints ? this.#pointing(slot, body, joints.points) : null;
      if (hand && tip && began && this.grab.squeeze(slot.index, hand, tip, now, pointing)) input.pulse(slot, 0.5, 40);
      if (this.grab.held?.slot === slot.index && (!slot.squeezing || !hand)) this.#release(slot.index);
    }
    const held = this.grab.held ? input.slots[this.grab.held.slot] : null;
    const hand = held && body ? this.#hand(held, body) : null;
    const pointing = held && body && joints ? this.#pointing(held, body, joints.points) : null;
    this.grab.setScale(menu.options.handOneToOne ? 1 : HAND_SCALE, hand, tip ?? null, pointing);
    if (held && hand && tip && joints) {
      input.takeEvents(held); // its trigger closes the gripper: it selects nothing under its ray meanwhile
      const position = this.trigger.update(input.trigger(held), joints.gripper ?? [], now);
      if (position !== null) actions.grip(position);
      const linear = this.grab.follow(hand, tip, now);
      actions.jogArm(linear, this.grab.turn(pointing?.hand ?? null, pointing?.dir ?? null));
      this.moving = true;
    } else if (this.moving) {
      this.grab.held = null; // the robot was deselected or its arm went: the hand holds nothing
      this.trigger.reset();
      actions.jogArm([0, 0, 0]);
      this.moving = false;
    }
    this.#showRefusal(robot ? arms.refusal(robot, now) : null, body, tip);
    const holding = this.grab.held && robot ? robot : null;
    this.gripperCamera.update(holding, holding ? this.host.armCamera(holding) : null, body, tip);
  }

  /** Outside VR: nothing is held, and the gripper's camera stops. */
  idle() {
    this.gripperCamera.update(null, null, undefined, undefined);
  }

  /** The relay refused a motion of `robot`'s arm: the hand holding it feels it. @param {string} robot */
  refused(robot) {
    const held = this.grab.held;
    if (held && robot === this.host.menu.selected) this.host.input.pulse(this.host.input.slots[held.slot], 0.8, 80);
  }

  /** @param {number} slot */
  #release(slot) {
    this.grab.release(slot);
    this.trigger.reset();
  }

  /**
   * The refusal's reason over the gripper, while it is news.
   * @param {string | null} reason @param {THREE.Object3D | undefined} body @param {number[] | undefined} tip
   */
  #showRefusal(reason, body, tip) {
    const sprite = this.label.sprite;
    sprite.visible = reason !== null && body !== undefined && tip !== undefined;
    if (!sprite.visible || !body || !tip) return;
    this.label.set(['Refused', /** @type {string} */ (reason)], { accent: '#e0a000' });
    body.localToWorld(sprite.position.set(tip[0], tip[2], -tip[1]));
    sprite.position.y += LABEL_ABOVE;
    sprite.parent?.worldToLocal(sprite.position);
  }

  /**
   * The hand's position in the arm's base link, or null while it is not tracked.
   * @param {import('./xr_input.js').InputSlot} slot @param {THREE.Object3D} body
   * @returns {[number, number, number] | null}
   */
  #hand(slot, body) {
    const handedness = slot.source?.handedness;
    const wrist = handedness === 'left' || handedness === 'right' ? this.host.input.wrist(handedness) : null;
    const carrier = wrist?.carrier ?? slot.grip;
    if (!carrier.visible && !wrist?.hand) return null;
    carrier.getWorldPosition(world);
    const local = body.worldToLocal(world);
    return [local.x, -local.z, local.y];
  }

  /**
   * The hand's orientation and the tip's direction in the arm's base link, or null (no tracked hand, no wrist link).
   * @param {import('./xr_input.js').InputSlot} slot @param {THREE.Object3D | undefined} body
   * @param {number[][]} points the joints' skeleton, base link to tip
   * @returns {import('../arm_grab.js').Pointing | null}
   */
  #pointing(slot, body, points) {
    if (!body || points.length < 2) return null;
    const [a, b] = points.slice(-2);
    const length = Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    const handedness = slot.source?.handedness;
    const wrist = handedness === 'left' || handedness === 'right' ? this.host.input.wrist(handedness) : null;
    const carrier = wrist?.carrier ?? slot.grip;
    if (length === 0 || (!carrier.visible && !wrist?.hand)) return null;
    carrier.getWorldQuaternion(turned);
    body.getWorldQuaternion(bodyTurn);
    // In the body's frame, then its axes renamed as the base link's: q_base = TO_BASE * q_body * TO_BASE^-1.
    turned.premultiply(bodyTurn.invert()).premultiply(TO_BASE).multiply(FROM_BASE);
    const dir = /** @type {[number, number, number]} */ ([0, 1, 2].map((i) => (b[i] - a[i]) / length));
    return { hand: [turned.x, turned.y, turned.z, turned.w], dir };
  }

  dispose() {
    this.gripperCamera.dispose();
    this.label.sprite.removeFromParent();
    this.label.dispose();
  }
}
