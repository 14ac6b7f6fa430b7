// @ts-check
/** The lens models against the reference values that docs/lenses.md gives and tests/test_lens.py pins. */
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  directionToUv,
  fieldHalfAngle,
  fisheyeFold,
  hemisphereGeometry,
  intrinsics,
  projectOptical,
  rho,
} from '../src/lens.js';

const DEG = Math.PI / 180;
/** An optical-frame direction at theta from the axis, azimuth phi (0 = right, 90 = down). */
const optical = (/** @type {number} */ theta, phi = 0) =>
  /** @type {[number, number, number]} */ ([
    Math.sin(theta) * Math.cos(phi),
    Math.sin(theta) * Math.sin(phi),
    Math.cos(theta),
  ]);
/** The same direction in three.js (forward -z, +y up). */
const three = (/** @type {number} */ theta, phi = 0) => {
  const [x, y, z] = optical(theta, phi);
  return /** @type {[number, number, number]} */ ([x, -y, -z]);
};
/** @param {number} a @param {number} b @param {number} [eps] */
const close = (a, b, eps = 1e-3) => assert.ok(Math.abs(a - b) < eps, `${a} != ${b}`);

test('docs/lenses.md reference radii on a 640 x 640 image (centre 319.5), right and down', () => {
  const table = {
    equidistant: { fov: 180, r: [0, 106.667, 160.0, 213.333, 320.0] },
    equisolid: { fov: 180, r: [0, 117.128, 173.183, 226.274, 320.0] },
    stereographic: { fov: 180, r: [0, 85.744, 132.548, 184.752, 320.0] },
    pinhole: { fov: 90, r: [0, 184.752, 320.0] },
  };
  const angles = [0, 30, 45, 60, 90];
  for (const [model, { fov, r }] of Object.entries(table)) {
    const lens = { model, fov };
    r.forEach((radius, i) => {
      const [u, v] = projectOptical(lens, ...optical(angles[i] * DEG, 0), 640, 640);
      close(u, 319.5 + radius);
      close(v, 319.5);
      const [u2, v2] = projectOptical(lens, ...optical(angles[i] * DEG, 90 * DEG), 640, 640);
      close(u2, 319.5);
      close(v2, 319.5 + radius);
    });
  }
  close(intrinsics({ model: 'equidistant', fov: 180 }, 640, 640).fx, 203.718);
  close(intrinsics({ model: 'equisolid', fov: 180 }, 640, 640).fx, 226.274);
  close(intrinsics({ model: 'stereographic', fov: 180 }, 640, 640).fx, 160.0);
  close(intrinsics({ model: 'pinhole', fov: 90 }, 640, 640).fx, 320.0);
});

test('docs/lenses.md opencv_fisheye reference: the SurroundVision front camera', () => {
  const lens = {
    model: 'opencv_fisheye',
    fov: 140,
    K: [774.6536281807633, 0, 987.610615957488, 0, 776.8351403236894, 592.2748935047063, 0, 0, 1],
    D: [-0.019489941171064756, -0.0030279815071226094, -0.0006303865899399078, 0.0000929330887373027],
  };
  close(rho(lens, 30 * DEG), 0.520675, 1e-6);
  close(rho(lens, 60 * DEG), 1.020273, 1e-6);
  const right = projectOptical(lens, ...optical(30 * DEG, 0), 1920, 1080);
  close(right[0], 1390.954);
  close(right[1], 592.275);
  const down = projectOptical(lens, ...optical(30 * DEG, 90 * DEG), 1920, 1080);
  close(down[0], 987.611);
  close(down[1], 996.754);
  const down60 = projectOptical(lens, ...optical(60 * DEG, 90 * DEG), 1920, 1080);
  close(down60[1], 1384.858);
  close(fieldHalfAngle(lens), 70 * DEG, 1e-9); // fov/2 comes before this polynomial's fold
  // A polynomial that folds: k1 = -0.2 makes 1 + 3 k1 s vanish at s = 1/0.6.
  close(fisheyeFold({ model: 'opencv_fisheye', fov: 360, D: [-0.2, 0, 0, 0] }), Math.sqrt(1 / 0.6), 1e-9);
});

test('texture coordinates: pixel centres, bottom-up image, image centre straight ahead, rim at fov/2', () => {
  for (const model of ['equidistant', 'equisolid', 'stereographic']) {
    const lens = { model, fov: 190 };
    const [s0, t0] = directionToUv(lens, 0, 0, -1, 640, 480);
    close(s0, 0.5, 1e-12);
    close(t0, 0.5, 1e-12);
    // The rim to the right: the circle's diameter is min(w, h) = 480.
    const [s, t] = directionToUv(lens, ...three(95 * DEG, 0), 640, 480);
    close(s, (320 + 240) / 640, 1e-9);
    close(t, 0.5, 1e-9);
    // Upwards in the world is the top of the image: a larger t once the image is uploaded bottom-up.
    const [su, tu] = directionToUv(lens, 0, Math.sin(95 * DEG), -Math.cos(95 * DEG), 640, 480);
    close(su, 0.5, 1e-9);
    close(tu, 1, 1e-9);
  }
  // Pinhole: fov spans the full width, not the circle.
  const [sp] = directionToUv({ model: 'pinhole', fov: 90 }, ...three(45 * DEG, 0), 640, 480);
  close(sp, 1, 1e-9);
});

test('the cap spans the field, its UVs are the lens mapping, and its triangles face the centre', () => {
  close(fieldHalfAngle({ model: 'equidistant', fov: 180 }), 90 * DEG, 1e-12);
  close(fieldHalfAngle({ model: 'pinhole', fov: 100 }), 50 * DEG, 1e-12);
  close(fieldHalfAngle({ model: 'equidistant', fov: 359 }), 179.5 * DEG, 1e-12);
  const lens = { model: 'equisolid', fov: 180 };
  const g = hemisphereGeometry(lens, 640, 640, { radius: 2, rings: 8, segments: 16 });
  assert.equal(g.positions.length / 3, 9 * 17);
  assert.equal(g.indices.length, 8 * 16 * 6);
  for (let k = 0; k < g.positions.length / 3; k++) {
    const [x, y, z] = g.positions.slice(3 * k, 3 * k + 3);
    close(Math.hypot(x, y, z), 2, 1e-5);
    const [u, v] = directionToUv(lens, x, y, z, 640, 640);
    close(g.uvs[2 * k], u, 1e-5);
    close(g.uvs[2 * k + 1], v, 1e-5);
    assert.ok(u >= -1e-6 && u <= 1 + 1e-6 && v >= -1e-6 && v <= 1 + 1e-6);
  }
  const p = (/** @type {number} */ i) => Array.from(g.positions.slice(3 * i, 3 * i + 3));
  for (let t = 0; t < g.indices.length; t += 3) {
    const [a, b, c] = [p(g.indices[t]), p(g.indices[t + 1]), p(g.indices[t + 2])];
    const e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    const e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    const n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    if (Math.hypot(n[0], n[1], n[2]) < 1e-9) continue; // the pole's degenerate triangles
    assert.ok(n[0] * a[0] + n[1] * a[1] + n[2] * a[2] < 0, 'a triangle faces outwards');
  }
});

test('an unknown lens model, or a fisheye without K and D, is an error that says what is expected', () => {
  assert.throws(() => directionToUv({ model: 'orthographic', fov: 90 }, 0.1, 0, -1, 10, 10), /equidistant/);
  assert.throws(
    () => directionToUv({ model: 'opencv_fisheye', fov: 180 }, 0.1, 0, -1, 10, 10),
    /opencv_fisheye needs K/,
  );
});
