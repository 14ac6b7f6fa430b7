// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { count, statusWords } from '../src/wording.js';
import { InspectionModel } from '../src/inspection_model.js';

test('one step, two steps, no steps; an irregular plural', () => {
  assert.equal(count(1, 'step'), '1 step');
  assert.equal(count(2, 'step'), '2 steps');
  assert.equal(count(0, 'step'), '0 steps');
  assert.equal(count(1, 'child', 'children'), '1 child');
  assert.equal(count(3, 'child', 'children'), '3 children');
});

test('a mission of one step is done "(1 step)"', () => {
  const model = new InspectionModel();
  const mission = { id: 'm1', robot: 'robot1', state: 'running', steps: [{ inspect: 'spill' }], step: 0, reason: null };
  model.apply(/** @type {any} */ ({ identifier: 'mission', ...mission }));
  const notices = model.apply(/** @type {any} */ ({ identifier: 'mission', ...mission, state: 'done' }));
  assert.deepEqual(
    notices.map((n) => n.text),
    ["robot1's mission done (1 step)"],
  );
});

test("a finding's status in words, as the report has them; a status a newer relay adds reads as its code", () => {
  assert.deepEqual(['ok', 'anomaly', 'needs_review', 'changed', 'false_alarm'].map(statusWords), [
    'OK',
    'Anomaly',
    'Needs review',
    'Changed since last round',
    'False alarm',
  ]);
  assert.equal(statusWords('out_of_reach'), 'out of reach');
});
