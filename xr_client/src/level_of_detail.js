// @ts-check
/**
 * Which robots are drawn with their full model and which with the shared low-poly shape. The demo's robot.glb is
 * 59,000 vertices: 100 of them are 5.9 M vertices a frame (twice in VR), and with them SwiftShader drew 3 frames in
 * 43 s (0.07 fps) and held the page's main thread for seconds at a time (measured 2026-11-23, bench client_frame).
 * The full model is for the few robots near enough to be looked at; the others are the instanced built-in shape
 * (view/fleet_instances.js), a dozen pixels from across the site either way. Pure: test/level_of_detail.test.js.
 */

/** Robots drawn with their full model at most: the demo's three all keep theirs. */
export const DETAILED_MAX = 4;

/**
 * At most, on a software renderer (render_quality.js: lowQuality): none, every robot is the shared shape. The demo's
 * three full models are 144 k triangles, 288 k a VR frame (two eyes): the emulated headset on SwiftShader drew 4.3
 * frames/s with them, 6.3 with the nearest one only, 11.8 with none (the twin itself is 4.6 k triangles; 2026-11-27).
 */
export const DETAILED_MAX_LOW_QUALITY = 0;

/**
 * The indices of the `max` smallest distances (ties: the lower index), in no particular order. Allocates only its
 * result's Set, which the caller may pass back in to be reused.
 * @param {ArrayLike<number>} distances per robot; NaN or Infinity: never detailed (no pose yet, no model)
 * @param {number} [max] @param {Set<number>} [out]
 * @returns {Set<number>}
 */
export function nearestDetailed(distances, max = DETAILED_MAX, out = new Set()) {
  out.clear();
  for (let k = 0; k < max; k++) {
    let best = -1;
    for (let i = 0; i < distances.length; i++) {
      const d = distances[i];
      if (!Number.isFinite(d) || out.has(i)) continue;
      if (best < 0 || d < distances[best]) best = i;
    }
    if (best < 0) break;
    out.add(best);
  }
  return out;
}
