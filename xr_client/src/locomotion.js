// @ts-check
/**
 * Locomotion and comfort without WebGL: snap turn with re-arming, the teleport stick gesture, smooth
 * locomotion speeds and the vignette strength. The view moves the operator's rig from these results.
 */

export const SNAP_ANGLE = Math.PI / 6; // 30 degrees
export const SNAP_TRIGGER = 0.7; // stick x beyond this turns once...
export const SNAP_REARM = 0.3; // ...and turns again only after it came back inside this
export const TELEPORT_AIM = 0.6; // stick pushed forward beyond this shows the arc
export const TELEPORT_RELEASE = 0.25; // and back inside this teleports
export const SMOOTH_SPEED = 1.5; // m/s at full deflection
export const SEATED_HEIGHT_OFFSET = 0.45; // m added to a seated operator's eye height

export class SnapTurn {
  constructor() {
    this.armed = true;
  }

  /** @param {number} x stick x @returns {number} the yaw change to apply now (radians, + = left) */
  update(x) {
    if (this.armed && Math.abs(x) >= SNAP_TRIGGER) {
      this.armed = false;
      return x > 0 ? -SNAP_ANGLE : SNAP_ANGLE;
    }
    if (!this.armed && Math.abs(x) <= SNAP_REARM) this.armed = true;
    return 0;
  }
}

export class TeleportGesture {
  constructor() {
    this.aiming = false;
  }

  /**
   * @param {number} y stick y (forward is negative)
   * @returns {'idle' | 'aim' | 'teleport' | 'cancel'} `teleport` once, when a forward push is released
   */
  update(y) {
    if (!this.aiming) {
      if (-y >= TELEPORT_AIM) {
        this.aiming = true;
        return 'aim';
      }
      return 'idle';
    }
    if (-y <= TELEPORT_RELEASE) {
      this.aiming = false;
      return 'teleport';
    }
    return 'aim';
  }

  cancel() {
    this.aiming = false;
  }
}

/**
 * Smooth locomotion: a stick as a velocity in the operator's heading frame (scene units, m/s).
 * @param {number} x @param {number} y @param {number} headingYaw rotation about +y of the view
 * @param {number} [deadzone]
 * @returns {[number, number]} velocity along scene x and z
 */
export function smoothVelocity(x, y, headingYaw, deadzone = 0.2) {
  const r = Math.hypot(x, y);
  if (r <= deadzone) return [0, 0];
  const k = (Math.min(1, (r - deadzone) / (1 - deadzone)) * SMOOTH_SPEED) / r;
  const c = Math.cos(headingYaw);
  const s = Math.sin(headingYaw);
  // Local (x right, z back = stick y) rotated about +y by headingYaw.
  const lx = x * k;
  const lz = y * k;
  return [c * lx + s * lz, -s * lx + c * lz];
}

/**
 * The comfort vignette: strength 0..1 from the rig's linear (m/s) and angular (rad/s) speed, eased so
 * that it fades in quickly and out slowly.
 * @param {number} current @param {number} linearSpeed @param {number} angularSpeed @param {number} dt s
 */
export function vignetteStrength(current, linearSpeed, angularSpeed, dt) {
  const target = Math.min(1, linearSpeed / SMOOTH_SPEED + angularSpeed / 2);
  const rate = target > current ? 8 : 2;
  return current + (target - current) * Math.min(1, rate * dt);
}
