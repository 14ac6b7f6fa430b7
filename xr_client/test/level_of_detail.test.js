// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { DETAILED_MAX, nearestDetailed } from '../src/level_of_detail.js';

test('only the nearest robots get their full model', () => {
  const distances = [12, 3, 40, 7, 2, 25, 9];
  assert.deepEqual([...nearestDetailed(distances, 3)].sort(), [1, 3, 4]);
  // The demo's three robots keep their models wherever the operator stands.
  assert.equal(nearestDetailed([30, 50, 80]).size, 3);
  assert.ok(DETAILED_MAX >= 3);
});

test('robots without a pose or a model are never detailed; the result set is reused', () => {
  const out = new Set([99]);
  const got = nearestDetailed([Infinity, NaN, 5, 6], 3, out);
  assert.equal(got, out);
  assert.deepEqual([...got].sort(), [2, 3]);
  assert.equal(nearestDetailed([], 4).size, 0);
  assert.deepEqual([...nearestDetailed([1, 1, 1], 2)].sort(), [0, 1]); // ties: the first ones
});
