// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ATLAS_MAX, AtlasLayout } from '../src/atlas_layout.js';

test('a hundred labels share one atlas, in cells that do not overlap', () => {
  const layout = new AtlasLayout(100, 256, 75, 2048);
  assert.equal(layout.columns, 8);
  assert.equal(layout.rows, 13);
  assert.equal(layout.width, 2048);
  assert.equal(layout.height, 13 * 75);
  assert.equal(layout.capacity, 100);
  const seen = new Set();
  for (let i = 0; i < 100; i++) {
    const c = /** @type {import('../src/atlas_layout.js').Cell} */ (layout.cell(i));
    assert.ok(c.x >= 0 && c.y >= 0 && c.x + c.w <= layout.width && c.y + c.h <= layout.height, JSON.stringify(c));
    const key = `${c.x},${c.y}`;
    assert.ok(!seen.has(key), key);
    seen.add(key);
    // Texture coordinates cover exactly the cell's pixels (v from the top: the atlas is not flipped).
    assert.equal(c.u0 * layout.width, c.x);
    assert.equal(c.u1 * layout.width, c.x + c.w);
    assert.ok(Math.abs(c.v0 * layout.height - c.y) < 1e-9 && Math.abs(c.v1 * layout.height - (c.y + c.h)) < 1e-9);
  }
  assert.equal(layout.cell(100), null);
  assert.equal(layout.cell(-1), null);
});

test('a small fleet gets a small atlas; a huge one is capped at the texture limit', () => {
  const three = new AtlasLayout(3, 256, 75, 2048);
  assert.deepEqual([three.width, three.height], [768, 75]);
  const none = new AtlasLayout(0, 256, 75, 2048);
  assert.ok(none.width > 0 && none.height > 0); // a valid texture even before the fleet is known
  assert.equal(none.cell(0), null);
  const huge = new AtlasLayout(5000, 256, 75, 2048);
  assert.ok(huge.height <= ATLAS_MAX);
  assert.equal(huge.capacity, 8 * Math.floor(ATLAS_MAX / 75));
  assert.equal(huge.cell(huge.capacity), null);
  assert.throws(() => new AtlasLayout(1, 4096, 75, 2048));
});
