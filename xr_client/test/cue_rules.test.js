// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  CueRules,
  HAPTIC_NEAR_M,
  TICK_FASTEST_MS,
  TICK_SLOWEST_MS,
  WARNING_REPEAT_MS,
  hapticFor,
  tickInterval,
} from '../src/cue_rules.js';

/** @param {Partial<import('../src/cue_rules.js').RobotView>} o @returns {import('../src/cue_rules.js').RobotView} */
const robot = (o) => ({ name: 'robot1', x: 0, y: 0, warnings: [], goal: null, latched: false, ...o });

test('a warning sounds when its sensor crosses, repeats while it stays over, stops when it drops', () => {
  const rules = new CueRules();
  assert.deepEqual(rules.update([robot({})], 0), []);
  assert.deepEqual(rules.update([robot({ warnings: ['gas'] })], 100), [{ kind: 'warning', robot: 'robot1' }]);
  assert.deepEqual(
    rules.update([robot({ warnings: ['gas'] })], 100 + WARNING_REPEAT_MS - 1),
    [],
    'not before the repeat',
  );
  assert.deepEqual(rules.update([robot({ warnings: ['gas'] })], 100 + WARNING_REPEAT_MS), [
    { kind: 'warning', robot: 'robot1' },
  ]);
  assert.deepEqual(rules.update([robot({})], 5000), [], 'back under: quiet');
  assert.deepEqual(
    rules.update([robot({ warnings: ['gas'] })], 5100),
    [{ kind: 'warning', robot: 'robot1' }],
    'over again: at once',
  );
});

test('goal accepted, goal refused, estop: once each, on the change', () => {
  const rules = new CueRules();
  rules.update([robot({ goal: 'pending' })], 0);
  assert.deepEqual(rules.update([robot({ goal: 'active' })], 10), [{ kind: 'goal_accepted', robot: 'robot1' }]);
  assert.deepEqual(rules.update([robot({ goal: 'active' })], 20), []);
  assert.deepEqual(rules.update([robot({ goal: 'error' })], 30), [{ kind: 'goal_refused', robot: 'robot1' }]);
  assert.deepEqual(rules.update([robot({ latched: true })], 60), [{ kind: 'estop', robot: 'robot1' }]);
  assert.deepEqual(rules.update([robot({ latched: true })], 70), []);
});

test('a fleet-wide estop is one earcon, not one per robot', () => {
  const rules = new CueRules();
  rules.update([robot({}), robot({ name: 'robot2' })], 0);
  assert.deepEqual(rules.update([robot({ latched: true }), robot({ name: 'robot2', latched: true })], 10), [
    { kind: 'estop', robot: null },
  ]);
});

test('hazard ticks: slow at nothing, faster as the reading rises, capped; due at their interval', () => {
  assert.equal(tickInterval(0, 100), TICK_SLOWEST_MS);
  assert.ok(tickInterval(50, 100) < tickInterval(20, 100));
  assert.ok(tickInterval(100, 100) < tickInterval(50, 100));
  assert.equal(tickInterval(400, 100), TICK_FASTEST_MS, 'capped at twice the level');
  assert.equal(tickInterval(100, 0), TICK_SLOWEST_MS, 'no level: the slowest');
  assert.equal(tickInterval(Number.NaN, 100), TICK_SLOWEST_MS);
  const rules = new CueRules();
  assert.equal(rules.tick(100, 100, 0), true, 'the first at once');
  const interval = tickInterval(100, 100);
  assert.equal(rules.tick(100, 100, interval - 1), false);
  assert.equal(rules.tick(100, 100, interval), true);
  rules.stopTicks();
  assert.equal(rules.tick(0, 100, interval + 1), true, 'switched on again: at once');
});

test('haptics: estop, lease lost and refusals always; warnings only near the selected robot; good news none', () => {
  const selected = { name: 'robot1', x: 0, y: 0 };
  assert.deepEqual(hapticFor({ kind: 'estop', robot: null }, { selected: null, at: null }), {
    intensity: 1,
    ms: 120,
    pulses: 3,
  });
  assert.ok(hapticFor({ kind: 'lease_lost', robot: 'robot1' }, { selected, at: null }));
  assert.ok(hapticFor({ kind: 'goal_refused', robot: 'robot1' }, { selected, at: null }));
  assert.equal(hapticFor({ kind: 'goal_accepted', robot: 'robot1' }, { selected, at: null }), null);
  assert.ok(
    hapticFor({ kind: 'warning', robot: 'robot2' }, { selected, at: { x: HAPTIC_NEAR_M - 0.1, y: 0 } }),
    'near',
  );
  assert.equal(
    hapticFor({ kind: 'warning', robot: 'robot2' }, { selected, at: { x: HAPTIC_NEAR_M + 0.1, y: 0 } }),
    null,
    'far',
  );
  assert.ok(
    hapticFor({ kind: 'warning', robot: 'robot1' }, { selected, at: { x: 50, y: 0 } }),
    'the selected robot itself',
  );
  assert.equal(
    hapticFor({ kind: 'warning', robot: 'robot2' }, { selected: null, at: { x: 0, y: 0 } }),
    null,
    'nothing selected',
  );
});
