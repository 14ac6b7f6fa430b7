// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { COVERED_OPACITY, declutter, labelRect } from '../src/label_declutter.js';

const GHOST = Math.fround(COVERED_OPACITY); // as a Float32Array holds it

test('of two labels that cover each other the more important one is drawn, the other a ghost', () => {
  // 0 and 1 overlap by half; 2 touches 0 only at a corner; 3 is not drawn.
  const rects = [0, 0, 100, 30, 50, 0, 150, 30, 95, 28, 195, 58, NaN, 0, 0, 0];
  const out = new Float32Array(4);
  declutter(rects, [0, 1, 2, 3], out);
  assert.deepEqual([...out], [1, GHOST, 1, 1]);
  // The order decides, not the index: the selected robot (1) first.
  declutter(rects, [1, 0, 2, 3], out);
  assert.deepEqual([...out], [GHOST, 1, 1, 1]);
  // A ghost hides nothing: 2 behind the covered 1 stays drawn even though it overlaps it.
  const chain = [0, 0, 100, 30, 40, 0, 140, 30, 90, 0, 190, 30];
  declutter(chain, [0, 1, 2], out);
  assert.deepEqual([...out.slice(0, 3)], [1, GHOST, 1]);
  // A small label drawn first is not hidden under a large one: half of it would be, so the large one is the ghost.
  const sizes = [0, 0, 10, 10, 5, 0, 105, 30];
  declutter(sizes, [0, 1], out);
  assert.deepEqual([...out.slice(0, 2)], [1, GHOST]);
});

test("a label's rectangle is its quad's corners as the camera projects them, on the picture's pixels", async () => {
  const { PerspectiveCamera, Vector3 } = await import('three');
  const camera = new PerspectiveCamera(60, 1280 / 800, 0.1, 100);
  camera.position.set(1, 2, 3);
  camera.lookAt(4, 1, -5);
  camera.updateMatrixWorld();
  const m = camera.projectionMatrix.elements;
  const rects = new Float32Array(8);
  // A quad 1 m wide and 0.5 m high, 6 m in front of the camera, a little left and up.
  labelRect(m, -0.7, 0.2, 0.3, 0.7, -6, 1280, 800, rects, 1);
  /** A view-space point where three.js puts it on the 1280 x 800 page. @param {number} x @param {number} y */
  const page = (x, y) => {
    const p = new Vector3(x, y, -6).applyMatrix4(camera.matrixWorld).project(camera);
    return [((p.x + 1) / 2) * 1280, ((1 - p.y) / 2) * 800];
  };
  const [[x0, y1], [x1, y0]] = [page(-0.7, 0.2), page(0.3, 0.7)];
  [x0, y0, x1, y1].forEach((v, k) => assert.ok(Math.abs(rects[4 + k] - v) < 1e-2, `${k}: ${rects[4 + k]} vs ${v}`));
  assert.ok(rects[4] < rects[6] && rects[5] < rects[7]);
  // An XR eye's frustum is asymmetric (wider toward the ear): its shift is applied too.
  const eye = new PerspectiveCamera();
  eye.projectionMatrix.makePerspective(-0.5, 0.2, 0.3, -0.4, 0.1, 100);
  labelRect(eye.projectionMatrix.elements, 0, 0, 0, 0, -1, 2, 2, rects, 0);
  const centre = new Vector3(0, 0, -1).applyMatrix4(eye.projectionMatrix);
  assert.ok(Math.abs(rects[0] - (centre.x + 1)) < 1e-5 && Math.abs(rects[1] - (1 - centre.y)) < 1e-5);
  assert.ok(Math.abs(centre.x) > 0.1, 'the frustum is asymmetric');
  // Behind the camera: not drawn.
  labelRect(m, -0.5, 0, 0.5, 0.5, 2, 1280, 800, rects, 1);
  assert.ok(Number.isNaN(rects[4]));
});
