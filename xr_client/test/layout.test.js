// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { freeRect, isCompact, scaleBar } from '../src/layout.js';

const viewport = { width: 1280, height: 800 };
const header = { left: 0, top: 0, right: 1280, bottom: 44 };
const menu = { left: 12, top: 52, right: 312, bottom: 560 };
const sensors = { left: 948, top: 538, right: 1268, bottom: 788 };
const pov = { left: 708, top: 64, right: 1268, bottom: 484 };

/** @param {import('../src/layout.js').Rect} r @param {import('../src/layout.js').Rect} p */
const overlaps = (r, p) => r.left < p.right && p.left < r.right && r.top < p.bottom && p.top < r.bottom;

test('the free part of the window avoids every panel and is the largest such rectangle', () => {
  const free = freeRect(viewport, [header, menu, sensors]);
  for (const p of [header, menu, sensors]) assert.ok(!overlaps(free, p), JSON.stringify({ free, p }));
  // Right of the menu, below the header, over the full height but for the sensor panel's corner: the widest band.
  assert.equal(free.left, menu.right + 8);
  assert.equal(free.top, header.bottom + 8);
  assert.ok((free.right - free.left) * (free.bottom - free.top) > 0.45 * 1280 * 800);
  // With Robot POV's panel on the right, the free part lies between the menu and that panel.
  const withPov = freeRect(viewport, [header, menu, sensors, pov]);
  assert.equal(withPov.left, menu.right + 8);
  assert.equal(withPov.right, pov.left - 8);
  assert.ok(!overlaps(withPov, pov) && !overlaps(withPov, menu));
});

test('no panels: the whole window; panels over nearly everything: the whole window too', () => {
  assert.deepEqual(freeRect(viewport, []), { left: 0, top: 0, right: 1280, bottom: 800 });
  const wall = { left: 0, top: 0, right: 1100, bottom: 800 };
  assert.deepEqual(freeRect(viewport, [wall]), { left: 0, top: 0, right: 1280, bottom: 800 });
  // A hidden panel (an empty rectangle, as getBoundingClientRect gives for display: none) is ignored.
  assert.deepEqual(freeRect(viewport, [{ left: 0, top: 0, right: 0, bottom: 0 }]), {
    left: 0,
    top: 0,
    right: 1280,
    bottom: 800,
  });
});

test('compact below 1100 x 700; the scale bar takes round lengths that fit', () => {
  assert.equal(isCompact({ width: 1024, height: 640 }), true);
  assert.equal(isCompact({ width: 1280, height: 800 }), false);
  assert.equal(isCompact({ width: 1280, height: 650 }), true);
  assert.deepEqual(scaleBar(30), { metres: 2, px: 60, text: '2 m' });
  assert.deepEqual(scaleBar(300), { metres: 0.2, px: 60, text: '20 cm' });
  assert.equal(scaleBar(2).text, '50 m');
  assert.ok(scaleBar(7).px <= 120 && scaleBar(7).px > 120 / 2.5);
});
