// @ts-check
/**
 * Lens models: where a direction seen by a robot's camera lands in its image, mirroring docs/lenses.md and
 * relay/lens.py to the pixel. No three.js: the hemisphere screen builds its UVs from these functions, and
 * node tests check them against the reference values of docs/lenses.md.
 *
 * Conventions (docs/lenses.md):
 * - the camera frame is OpenCV's optical frame: +z forward, +x right, +y down. A three.js direction
 *   (x, y, z) (looking along -z, +y up) is the optical direction (x, -y, -z);
 * - theta = atan2(hypot(x, y), z) from the optical axis, phi = atan2(y, x) in the image (0 right, 90° down);
 * - rho = g(theta): equidistant theta, equisolid 2 sin(theta/2), stereographic 2 tan(theta/2),
 *   pinhole tan(theta), opencv_fisheye theta (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸);
 * - u = cx + fx rho cos(phi), v = cy + fy rho sin(phi), in pixels whose centres are integers;
 * - circle models: R = min(width, height) / 2, fx = fy = R / g(fov/2), centred ((w-1)/2, (h-1)/2);
 *   pinhole: fov across the full width, fx = fy = (width/2) / tan(fov/2), centred;
 *   opencv_fisheye: fx, fy, cx, cy from K, in pixels of the image it was calibrated on;
 * - WebGL texture coordinates of pixel (u, v), the image uploaded bottom-up (flipY):
 *   s = (u + 0.5) / width, t = 1 - (v + 0.5) / height.
 */

/**
 * @typedef {import('./protocol.js').Lens} Lens the relay's lens description (hello.robots[].cameras[].lens)
 * @typedef {{fx: number, fy: number, cx: number, cy: number}} Intrinsics
 */

export const LENS_MODELS = Object.freeze(['equidistant', 'equisolid', 'stereographic', 'pinhole', 'opencv_fisheye']);

const DEG = Math.PI / 180;

/** @param {Lens} lens @returns {[number, number, number, number]} */
function distortion(lens) {
  const D = lens.D;
  if (!D || D.length !== 4) throw new Error('opencv_fisheye needs D (4 numbers: k1..k4)');
  return [D[0], D[1], D[2], D[3]];
}

/**
 * The normalised radius rho = g(theta) of a lens model.
 * @param {Lens} lens @param {number} theta radians
 */
export function rho(lens, theta) {
  switch (lens.model) {
    case 'equidistant':
      return theta;
    case 'equisolid':
      return 2 * Math.sin(theta / 2);
    case 'stereographic':
      return 2 * Math.tan(theta / 2);
    case 'pinhole':
      return Math.tan(theta);
    case 'opencv_fisheye': {
      const [k1, k2, k3, k4] = distortion(lens);
      const t2 = theta * theta;
      return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
    }
    default:
      throw new Error(`unknown lens model ${JSON.stringify(lens.model)}; expected one of ${LENS_MODELS.join(', ')}`);
  }
}

/**
 * fx, fy, cx, cy of a lens for an image of width x height (for opencv_fisheye: the calibration image).
 * @param {Lens} lens @param {number} width @param {number} height
 * @returns {Intrinsics}
 */
export function intrinsics(lens, width, height) {
  const cx = (width - 1) / 2;
  const cy = (height - 1) / 2;
  const half = (lens.fov * DEG) / 2;
  switch (lens.model) {
    case 'opencv_fisheye': {
      const K = lens.K;
      if (!K || K.length !== 9) throw new Error('opencv_fisheye needs K (9 numbers, row-major)');
      return { fx: K[0], fy: K[4], cx: K[2], cy: K[5] };
    }
    case 'pinhole': {
      const f = width / 2 / Math.tan(half);
      return { fx: f, fy: f, cx, cy };
    }
    default: {
      const f = Math.min(width, height) / 2 / rho(lens, half);
      return { fx: f, fy: f, cx, cy };
    }
  }
}

/**
 * The angle where the OpenCV fisheye polynomial stops increasing (its fold), or Infinity: the smallest
 * positive root s of 9 k4 s⁴ + 7 k3 s³ + 5 k2 s² + 3 k1 s + 1, as theta = sqrt(s).
 * @param {Lens} lens
 */
export function fisheyeFold(lens) {
  const [k1, k2, k3, k4] = distortion(lens);
  const f = (/** @type {number} */ s) => 1 + s * (3 * k1 + s * (5 * k2 + s * (7 * k3 + s * 9 * k4)));
  const top = Math.PI * Math.PI; // theta up to 180 degrees
  const steps = 2000;
  let previous = 0;
  for (let i = 1; i <= steps; i++) {
    const s = (top * i) / steps;
    if (f(s) <= 0) {
      let lo = previous;
      let hi = s;
      for (let k = 0; k < 60; k++) {
        const mid = (lo + hi) / 2;
        if (f(mid) > 0) lo = mid;
        else hi = mid;
      }
      return Math.sqrt((lo + hi) / 2);
    }
    previous = s;
  }
  return Infinity;
}

/**
 * Where a lens's field ends (radians from the axis): fov/2, earlier at a fisheye's fold; just under
 * 90 degrees for pinhole (no image there) and under 180 for the circle models (a full sphere has no rim).
 * @param {Lens} lens
 */
export function fieldHalfAngle(lens) {
  const half = (lens.fov * DEG) / 2;
  if (lens.model === 'pinhole') return Math.min(half, 89.5 * DEG);
  if (lens.model === 'opencv_fisheye') return Math.min(half, fisheyeFold(lens), 179.5 * DEG);
  return Math.min(half, 179.5 * DEG);
}

/**
 * A direction in the optical frame to a pixel (u, v).
 * @param {Lens} lens @param {number} x @param {number} y @param {number} z optical frame
 * @param {number} width @param {number} height image size (for opencv_fisheye: the calibration image)
 * @returns {[number, number]}
 */
export function projectOptical(lens, x, y, z, width, height) {
  const theta = Math.atan2(Math.hypot(x, y), z);
  const phi = Math.atan2(y, x);
  const { fx, fy, cx, cy } = intrinsics(lens, width, height);
  const r = rho(lens, theta);
  return [cx + fx * r * Math.cos(phi), cy + fy * r * Math.sin(phi)];
}

/**
 * Texture coordinates of a three.js direction (forward -z, +y up) for a bottom-up (flipY) image.
 * Directions outside the image come out outside [0, 1] (the screen paints them black).
 * @param {Lens} lens @param {number} x @param {number} y @param {number} z three.js frame
 * @param {number} width @param {number} height image size (for opencv_fisheye: the calibration image)
 * @returns {[number, number]}
 */
export function directionToUv(lens, x, y, z, width, height) {
  const [u, v] = projectOptical(lens, x, -y, -z, width, height);
  return [(u + 0.5) / width, 1 - (v + 0.5) / height];
}

/**
 * The geometry of the screen: a spherical cap of `radius` around the forward (-z) axis spanning theta in
 * [0, fieldHalfAngle], seen from inside, with UVs from the lens model: the image centre straight ahead, the
 * rim at half the field of view. `rings` steps in theta, `segments` in phi. Triangles face the centre.
 * @param {Lens} lens @param {number} width @param {number} height
 * @param {{radius?: number, rings?: number, segments?: number}} [options]
 */
export function hemisphereGeometry(lens, width, height, options = {}) {
  const radius = options.radius ?? 5;
  const rings = options.rings ?? 32;
  const segments = options.segments ?? 64;
  const half = fieldHalfAngle(lens);
  const columns = segments + 1;
  const count = (rings + 1) * columns;
  const positions = new Float32Array(count * 3);
  const uvs = new Float32Array(count * 2);
  for (let i = 0; i <= rings; i++) {
    const theta = (half * i) / rings;
    const st = Math.sin(theta);
    const ct = Math.cos(theta);
    for (let j = 0; j <= segments; j++) {
      const phi = (2 * Math.PI * j) / segments;
      const k = i * columns + j;
      const x = st * Math.cos(phi);
      const y = st * Math.sin(phi);
      const z = -ct;
      positions[3 * k] = x * radius;
      positions[3 * k + 1] = y * radius;
      positions[3 * k + 2] = z * radius;
      const [u, v] = directionToUv(lens, x, y, z, width, height);
      uvs[2 * k] = u;
      uvs[2 * k + 1] = v;
    }
  }
  const indices = new Uint32Array(rings * segments * 6);
  let n = 0;
  for (let i = 0; i < rings; i++) {
    for (let j = 0; j < segments; j++) {
      const a = i * columns + j;
      const b = a + columns;
      // Counter-clockwise as seen from the centre (inside the cap).
      indices.set([a, b, a + 1, b, b + 1, a + 1], n);
      n += 6;
    }
  }
  return { positions, uvs, indices, halfAngle: half };
}
