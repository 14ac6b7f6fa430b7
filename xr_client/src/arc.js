// @ts-check
/**
 * The pointer arc (goal pointer and teleport) as plain math: a parabola from the hand, sampled into
 * segments, and where it meets a horizontal floor. Scene coordinates (Y up), metres and seconds.
 */

/** @typedef {[number, number, number]} Vec3 */

export const ARC_SPEED = 7; // m/s launch speed: reaches ~5 m when aimed level from 1.2 m, ~10 m at 45 degrees
export const ARC_GRAVITY = 9.8;

/**
 * Points of the arc from `origin` along the unit `direction`, every `dt` seconds, until it drops below
 * `floorY` (the last point is then the exact crossing) or `maxPoints` is reached.
 * @param {Vec3} origin @param {Vec3} direction
 * @param {{speed?: number, gravity?: number, floorY?: number, dt?: number, maxPoints?: number}} [options]
 * @returns {{points: Vec3[], hit: Vec3 | null}}
 */
export function arcPoints(origin, direction, options = {}) {
  const speed = options.speed ?? ARC_SPEED;
  const g = options.gravity ?? ARC_GRAVITY;
  const floorY = options.floorY ?? 0;
  const dt = options.dt ?? 0.03;
  const maxPoints = options.maxPoints ?? 64;
  const [vx, vy, vz] = [direction[0] * speed, direction[1] * speed, direction[2] * speed];
  /** @type {Vec3[]} */
  const points = [origin];
  for (let i = 1; i < maxPoints; i++) {
    const t = i * dt;
    const y = origin[1] + vy * t - 0.5 * g * t * t;
    if (y <= floorY) {
      const tHit = floorCrossing(origin[1] - floorY, vy, g);
      /** @type {Vec3} */
      const hit = [origin[0] + vx * tHit, floorY, origin[2] + vz * tHit];
      points.push(hit);
      return { points, hit };
    }
    points.push([origin[0] + vx * t, y, origin[2] + vz * t]);
  }
  return { points, hit: null };
}

/**
 * Time at which a body at height h above the floor, with vertical speed vy, reaches the floor.
 * @param {number} h @param {number} vy @param {number} g
 */
export function floorCrossing(h, vy, g) {
  return (vy + Math.sqrt(vy * vy + 2 * g * Math.max(0, h))) / g;
}
