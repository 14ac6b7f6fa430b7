// @ts-check
/**
 * The operator's motion in VR, once per XR frame: the sticks (the right one drives the robot when Teleop is on, else
 * both snap-turn; the left one teleports along an arc, or moves smoothly), a hand's (or the eyes') pinch on nothing
 * aiming a teleport that its release lands, and the comfort vignette that follows the rig's motion.
 */
import * as THREE from 'three';
import { SnapTurn, TeleportGesture, smoothVelocity, vignetteStrength } from '../locomotion.js';

/**
 * Where the operator's head is and which way it faces (rad about up), as XRInteraction last read it.
 * @typedef {{position: THREE.Vector3, yaw: number}} Head
 */

export class XRMotion {
  /**
   * @param {{xrInput: import('./xr_input.js').XRInput, rig: THREE.Group, menu: import('../menu_state.js').MenuState,
   *   picking: import('./picking.js').Picking, teleportView: import('./comfort_view.js').TeleportView,
   *   vignette: import('./comfort_view.js').Vignette, locomotion: import('./xr_session.js').XRSessionController,
   *   actions: import('../app.js').OperatorActions}} host what motion reads and drives
   * @param {Head} head
   */
  constructor(host, head) {
    this.host = host;
    this.head = head;
    this.snapLeft = new SnapTurn();
    this.snapRight = new SnapTurn();
    this.teleport = new TeleportGesture();
    /**
     * A hand (or the eyes) pinching where nothing is to select: its arc (the eyes: a straight ray) aims a teleport,
     * its release lands it. @type {import('./xr_input.js').InputSlot | null}
     */
    this.pinchTeleport = null;
    /** @type {THREE.Vector3 | null} */
    this.teleportHit = null;
    this.vignette = 0;
    this.lastRig = new THREE.Vector3();
    this.lastRigYaw = 0;
  }

  /** Whether a hand's pinch on nothing may aim a teleport: free roam, the menu closed, no tool that pinches itself. */
  pinchTeleports() {
    const menu = this.host.menu;
    return menu.mode === 'free_roam' && !menu.open && menu.tool !== 'teleop' && menu.tool !== 'goal';
  }

  /** A pinch on nothing to select starts aiming a teleport. @param {import('./xr_input.js').InputSlot} slot */
  startPinch(slot) {
    this.pinchTeleport = slot;
  }

  /** The pinch that aims a teleport lets go: the operator lands where it aimed. */
  endPinch() {
    this.pinchTeleport = null;
    if (this.teleportHit) this.host.locomotion.teleportTo(this.teleportHit, this.head.position);
    this.teleportHit = null;
  }

  /** @param {number} dt s */
  sticks(dt) {
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
      if (menu.options.smooth && free) {
        const [vx, vz] = smoothVelocity(lx, ly, this.head.yaw);
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
          host.locomotion.teleportTo(this.teleportHit, this.head.position);
          this.teleportHit = null;
        }
      }
      if (Math.abs(ly) < 0.5 || !free) this.#turn(this.snapLeft.update(lx));
    } else {
      this.teleport.cancel();
    }
    const hand = this.pinchTeleport;
    if (hand && (!hand.source || !this.pinchTeleports()))
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
  comfort(dt) {
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

  /** Snap turn about the head. @param {number} angle */
  #turn(angle) {
    if (angle !== 0) this.host.locomotion.turnAbout(this.head.position, angle);
  }
}
