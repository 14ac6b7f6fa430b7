// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { WIPE_START, afterClip, wipeAt, wipeLabels } from '../src/before_after.js';

test("the wipe's position is a whole share of 0-100, a bad value the start", () => {
  assert.deepEqual(['10', 90, '-5', 130, '33.6', 'x', ''].map(wipeAt), [10, 90, 0, 100, 34, WIPE_START, 0]);
});

test('before is left of the divide, after right of it: as the labels under the slider read', () => {
  assert.equal(afterClip(10), 'inset(0 0 0 10%)');
  assert.equal(afterClip(100), 'inset(0 0 0 100%)');
});

test("the labels carry the times at hand: the before's from a finding about the baseline capture", () => {
  const time = (/** @type {number} */ s) => `t${s}`;
  const finding = { baseline: 'c-1', created: 200 };
  const held = [
    { capture: 'c-1', created: 120 },
    { capture: 'c-1', created: 100 },
    { capture: 'c-2', created: 200 },
  ];
  assert.deepEqual(wipeLabels(finding, held, time), { before: 'before (t100)', after: 'after (t200)' });
  assert.deepEqual(wipeLabels(finding, held.slice(2), time), { before: 'before', after: 'after (t200)' });
  assert.deepEqual(wipeLabels({ baseline: 'c-1', created: 0 }, [], time), { before: 'before', after: 'after' });
});

test('rounds in the same minute are told apart by their seconds; minutes apart, the minute is enough', () => {
  const at = (/** @type {number} */ created) => ({ capture: 'c-1', created });
  const t0 = 1_800_000_000; // a whole minute
  const near = wipeLabels({ baseline: 'c-1', created: t0 + 40 }, [at(t0 + 12)]);
  assert.match(near.before, /^before \(\d{4}-\d\d-\d\d \d\d:\d\d:12\)$/);
  assert.match(near.after, /^after \(\d{4}-\d\d-\d\d \d\d:\d\d:40\)$/);
  const far = wipeLabels({ baseline: 'c-1', created: t0 + 3600 }, [at(t0 + 12)]);
  assert.match(far.before, /^before \(\d{4}-\d\d-\d\d \d\d:\d\d\)$/);
  assert.match(far.after, /^after \(\d{4}-\d\d-\d\d \d\d:\d\d\)$/);
});
