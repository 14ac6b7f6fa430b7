// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  FADE_END,
  FADE_START,
  LABEL_ANGLE,
  LABEL_MAX,
  LABEL_MIN,
  labelHeight,
  labelOpacity,
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
