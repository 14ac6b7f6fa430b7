// @ts-check
/**
 * Where this page's operator looks from, as the relay records it (docs/protocol.md, `viewer`): the head's position
 * and facing and, in VR, each hand's or controller's position and ray, in the map frame (the scene's poses turned
 * with frames.js), a few times a second; and the way back, a recorded `avatar`'s map-frame poses into the scene.
 * No DOM, no WebGL: test/viewer_pose.test.js drives it.
 */
import { gltfToRos, mapToScene, rosToGltf, sceneToMap } from './frames.js';

/** The page sends its viewpoint this often (ms): 4 times a second, enough to follow a head, cheap to record. */
export const VIEWER_PERIOD_MS = 250;

/**
 * @typedef {[number, number, number]} Vec3
 * @typedef {{position: Vec3, direction: Vec3}} ScenePose a point and a unit direction in the scene (three.js world)
 * @typedef {{hand: 'left' | 'right', position: Vec3, direction: Vec3}} SceneHand
 * @typedef {import('./frames.js').MapToScene} MapToScene
 */

/** @param {number} v @param {number} digits */
function round(v, digits) {
  const f = 10 ** digits;
  return Math.round(v * f) / f + 0; // + 0: never -0 on the wire
}

/** A unit vector, or null for a zero or non-finite one. @param {number[]} v @returns {Vec3 | null} */
function unit(v) {
  const length = Math.hypot(v[0], v[1], v[2]);
  if (!Number.isFinite(length) || length < 1e-6) return null;
  return [v[0] / length, v[1] / length, v[2] / length];
}

/** A scene direction in the map frame (a rotation only). @param {MapToScene} t @param {Vec3} d */
export function directionToMap(t, d) {
  const [x, y, z] = gltfToRos(d[0], d[1], d[2]);
  const c = Math.cos(t.yaw);
  const s = Math.sin(t.yaw);
  return unit([c * x + s * y, -s * x + c * y, z]);
}

/** A map-frame direction in the scene. @param {MapToScene} t @param {number[]} d @returns {Vec3 | null} */
export function directionToScene(t, d) {
  const c = Math.cos(t.yaw);
  const s = Math.sin(t.yaw);
  const rotated = unit([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]]);
  return rotated && rosToGltf(rotated[0], rotated[1], rotated[2]);
}

/**
 * The `viewer` message of a head and hands seen in the scene: map frame, positions to the millimetre, directions to
 * 1e-4; null when the head's pose is not a pose (a zero or non-finite direction). A hand without one is left out.
 * `view`: what the operator looks through (a study counts its changes).
 * @param {MapToScene} t @param {ScenePose} head @param {SceneHand[]} [hands]
 * @param {import('./protocol.js').ViewerCommand['view']} [view]
 * @returns {import('./protocol.js').ViewerCommand | null}
 */
export function viewerMessage(t, head, hands = [], view = undefined) {
  /** @param {Vec3} p */
  const point = (p) => sceneToMap(t, p[0], p[1], p[2]).map((v) => round(v, 3));
  /** @param {Vec3} d */
  const direction = (d) => directionToMap(t, d)?.map((v) => round(v, 4)) ?? null;
  const look = direction(head.direction);
  const position = point(head.position);
  if (!look || !position.every(Number.isFinite)) return null;
  /** @type {import('./protocol.js').ViewerHand[]} */
  const seen = [];
  for (const hand of hands) {
    const ray = direction(hand.direction);
    const at = point(hand.position);
    if (ray && at.every(Number.isFinite) && !seen.some((h) => h.hand === hand.hand))
      seen.push({ hand: hand.hand, position: at, ray });
  }
  /** @type {import('./protocol.js').ViewerCommand} */
  const message = { identifier: 'viewer', head: { position, look }, hands: seen };
  if (view) message.view = view;
  return message;
}

/** A recorded pose back in the scene. @param {MapToScene} t @param {number[]} position @param {number[]} direction */
export function poseToScene(t, position, direction) {
  const d = directionToScene(t, direction);
  return d ? { position: mapToScene(t, position[0], position[1], position[2]), direction: d } : null;
}

/** When the next viewpoint is due: at most one every VIEWER_PERIOD_MS. */
export class ViewerPacer {
  #last = -Infinity;

  /** @param {number} [period] ms */
  constructor(period = VIEWER_PERIOD_MS) {
    this.period = period;
  }

  /** Whether one is due at `now` (page ms); if so, the next is a period later. @param {number} now */
  due(now) {
    if (now - this.#last < this.period) return false;
    this.#last = now;
    return true;
  }
}
