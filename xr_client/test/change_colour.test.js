// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  CHANGE_HIGH,
  CHANGE_LOW,
  changeColour,
  changeStrength,
  isChanged,
  sinceLastRound,
  STATUS_COLOURS,
} from '../src/change_colour.js';
import { InspectionModel } from '../src/inspection_model.js';

/** @param {Partial<import('../src/protocol.js').FindingMessage>} fields @returns {import('../src/protocol.js').FindingMessage} */
function finding(fields) {
  return {
    identifier: 'finding',
    id: 'f-1',
    capture: 'c-1',
    mission: 'm-1.robot1',
    target: 'spill',
    robot: 'robot1',
    x: 1.8,
    y: 8.2,
    status: 'ok',
    note: '',
    source: 'rule',
    region: null,
    image: null,
    readings: {},
    created: 100,
    updated: 100,
    change: null,
    baseline: null,
    before: null,
    trend: null,
    ...fields,
  };
}

test('a finding with no change data keeps its status colour', () => {
  for (const status of /** @type {const} */ (['ok', 'anomaly', 'needs_review'])) {
    assert.equal(changeColour(finding({ status })).colour, STATUS_COLOURS[status]);
  }
  assert.equal(isChanged(finding({ change: 0.01 })), false, 'under the threshold is no change');
  assert.equal(changeColour(finding({ change: 0.01 })).colour, STATUS_COLOURS.ok);
});

test('a change is orange at the threshold, magenta from 0.3, stronger as the score grows', () => {
  assert.equal(changeColour(finding({ status: 'changed' })).colour, CHANGE_LOW, 'a trend: changed, no score');
  assert.equal(changeColour(finding({ status: 'changed', change: 0.5 })).colour, CHANGE_HIGH);
  const small = changeColour(finding({ status: 'changed', change: 0.037 }));
  assert.equal(small.label, 'Changed 3.7 %');
  assert.notEqual(small.colour, CHANGE_LOW);
  assert.notEqual(small.colour, CHANGE_HIGH);
  assert.ok(changeStrength(0.037) < changeStrength(0.1) && changeStrength(0.1) < 1);
  assert.equal(changeStrength(0.02), 0);
  // A score over the threshold is a change even if the status says otherwise (an operator's ok keeps the score).
  assert.equal(isChanged(finding({ status: 'needs_review', change: 0.05 })), true);
  for (const f of [finding({ status: 'changed' }), finding({ change: 0.2 })]) {
    assert.ok(!Object.values(STATUS_COLOURS).includes(changeColour(f).colour), 'apart from every status colour');
  }
});

test('a false alarm is grey, whatever its score', () => {
  const f = changeColour(finding({ status: 'false_alarm', change: 0.2 }));
  assert.equal(f.colour, STATUS_COLOURS.false_alarm);
  assert.equal(f.label, 'False alarm');
});

test("since the last round: each target's newest mission, its changed findings only", () => {
  const findings = [
    finding({ id: 'old-change', mission: 'm-1', created: 10, status: 'changed', change: 0.1 }),
    finding({ id: 'new-ok', mission: 'm-2', created: 20 }),
    finding({ id: 'new-change', mission: 'm-2', created: 21, status: 'changed', change: 0.04 }),
    finding({ id: 'valve-change', target: 'valve', mission: 'm-1', created: 11, status: 'changed' }),
    finding({ id: 'valve-noise', target: 'valve', mission: 'm-1', created: 12, status: 'false_alarm', change: 0.1 }),
    finding({ id: 'operator', target: 'pump', mission: null, created: 30, status: 'changed' }),
  ];
  assert.deepEqual(
    sinceLastRound(findings).map((f) => f.id),
    ['new-change', 'valve-change'],
  );
  assert.deepEqual(sinceLastRound([]), []);
});

test('the model filters its findings since the last round while the switch is on', () => {
  const model = new InspectionModel(() => 0);
  model.apply(finding({ id: 'a', mission: 'm-1', created: 1 }));
  model.apply(finding({ id: 'b', mission: 'm-2', created: 2, status: 'changed', change: 0.05 }));
  model.apply(finding({ id: 'c', target: 'valve', mission: 'm-2', created: 3 }));
  assert.deepEqual(
    model.visible().map((f) => f.id),
    ['c', 'b', 'a'],
  );
  const version = model.version;
  model.setSinceLastRound(true);
  assert.ok(model.version > version, 'views redraw');
  assert.deepEqual(
    model.visible().map((f) => f.id),
    ['b'],
  );
  assert.deepEqual(model.visible({ status: 'ok' }), []);
  model.setSinceLastRound(false);
  assert.equal(model.visible().length, 3);
});
