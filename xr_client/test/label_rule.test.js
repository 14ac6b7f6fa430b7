// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  FADE_END,
  FADE_START,
  HEADSET_PX_PER_RAD,
  LABEL_ANGLE,
  LABEL_MAX,
  LABEL_MIN,
  LEGIBLE_PX,
  LINE_FONT,
  NAME_FONT,
  labelAngle,
  labelHeight,
  labelOpacity,
  smallestFont,
} from '../src/label_rule.js';

test('a label keeps about two degrees on screen, within its limits in metres', () => {
  assert.equal(labelHeight(10), LABEL_ANGLE * 10); // 0.35 m at 10 m
  assert.ok(Math.abs(labelHeight(10) / 10 - labelHeight(4) / 4) < 1e-12); // the same angle at 4 and 10 m
  assert.equal(labelHeight(0.5), LABEL_MIN); // not a wall of text at arm's length
  assert.equal(labelHeight(200), LABEL_MAX); // not a billboard across the site
});

test('labels fade out beyond a range, except the selected robot and a warning', () => {
  assert.equal(labelOpacity(3), 1);
  assert.equal(labelOpacity(FADE_START), 1);
  const middle = labelOpacity((FADE_START + FADE_END) / 2);
  assert.ok(Math.abs(middle - 0.5) < 1e-12, String(middle));
  assert.ok(labelOpacity(FADE_START + 1) > labelOpacity(FADE_START + 2)); // fading, not switching
  assert.equal(labelOpacity(FADE_END), 0);
  assert.equal(labelOpacity(100), 0);
  assert.equal(labelOpacity(100, true), 1);
  // The demo facility is 18 x 10 m: its three robots keep their labels from anywhere on the site.
  assert.ok(FADE_START >= Math.hypot(18, 10) * 0.75);
});

test('every line of a label is at least 12 px: two lines on a 1280 x 800 desktop, three on a Quest 3', () => {
  const desktop = 800 / 2 / Math.tan(Math.PI / 6); // a 60-degree view 800 px high: 693 px a radian
  for (const lines of [2, 3]) {
    for (const pxPerRad of [desktop, HEADSET_PX_PER_RAD]) {
      const angle = labelAngle(lines, pxPerRad);
      assert.ok(angle >= LABEL_ANGLE);
      // At 10 m (and 3 m), the label's height on the screen and its smallest font.
      for (const distance of [3, 10]) {
        const px = (labelHeight(distance, angle) / distance) * pxPerRad;
        assert.ok(smallestFont(px, lines) >= LEGIBLE_PX - 1e-9, `${lines} lines at ${distance} m: ${px} px`);
      }
    }
  }
  // The name is drawn larger than the lines under it; a screen sharp enough keeps the 2-degree rule.
  assert.ok(NAME_FONT > LINE_FONT);
  assert.equal(labelAngle(2, 100_000), LABEL_ANGLE);
  assert.ok(labelAngle(3, desktop) > labelAngle(2, desktop));
});
