// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { COVERED_OPACITY, declutter } from '../src/label_declutter.js';

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
});
