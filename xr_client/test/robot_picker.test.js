// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { detailsOf, fleetFacts, matchOf, naturalCompare, pickerRows, statusOf } from '../src/robot_picker.js';

/** @param {string} name @param {Partial<import('../src/robot_picker.js').RobotFacts>} [facts] */
function robot(name, facts = {}) {
  return { name, online: true, mode: 'idle', estopped: false, battery: null, mission: '', alerts: 0, ...facts };
}
/** robot1..robot20, idle. */
const TWENTY = Array.from({ length: 20 }, (_, i) => robot(`robot${i + 1}`));

test('names in natural order: robot2 before robot10, case aside', () => {
  const names = ['robot10', 'robot2', 'Robot1', 'robot100', 'robot20', 'alpha'];
  assert.deepEqual([...names].sort(naturalCompare), ['alpha', 'Robot1', 'robot2', 'robot10', 'robot20', 'robot100']);
  const rows = pickerRows(TWENTY, '', 'name').map((r) => r.name);
  assert.deepEqual(rows.slice(0, 3), ['robot1', 'robot2', 'robot3']);
  assert.deepEqual(rows.slice(-2), ['robot19', 'robot20']);
});

test('a search finds by name or number, the robot it names first: "17" is robot17, "1" robot1 then the others', () => {
  assert.deepEqual(
    pickerRows(TWENTY, '17', 'name').map((r) => r.name),
    ['robot17'],
  );
  const hundred = Array.from({ length: 100 }, (_, i) => robot(`robot${i + 1}`));
  assert.deepEqual(
    pickerRows(hundred, '17', 'name').map((r) => r.name),
    ['robot17'],
  );
  assert.deepEqual(
    pickerRows(hundred, '73', 'name').map((r) => r.name),
    ['robot73'],
  );
  const ones = pickerRows(hundred, '1', 'name').map((r) => r.name);
  assert.deepEqual(ones.slice(0, 4), ['robot1', 'robot10', 'robot11', 'robot12']);
  assert.equal(ones.length, 20); // robot1, 10-19, 21, 31, ..., 91, 100
  assert.equal(pickerRows(hundred, 'Robot 42', 'name')[0].name, 'robot42');
  assert.equal(pickerRows(hundred, 'rob', 'name').length, 100);
  assert.deepEqual(pickerRows(hundred, 'scout', 'name'), []);
  assert.equal(matchOf('scout_a', 'scout a'), 0);
  assert.equal(matchOf('robot117', '17'), 2);
});

test('a status in words, and sorted by status: E-STOPPED, offline, moving, idle, unheard', () => {
  const fleet = [
    robot('robot1'),
    robot('robot2', { mode: 'navigating' }),
    robot('robot3', { online: false }),
    robot('robot4', { estopped: true }),
    robot('robot5', { online: null, mode: null }),
    robot('robot10', { mode: 'teleop' }),
  ];
  const rows = pickerRows(fleet, '', 'status');
  assert.deepEqual(
    rows.map((r) => [r.name, r.status]),
    [
      ['robot4', 'E-STOPPED'],
      ['robot3', 'offline'],
      ['robot2', 'navigating'],
      ['robot10', 'teleop'],
      ['robot1', 'idle'],
      ['robot5', 'no status yet'],
    ],
  );
  assert.equal(statusOf(robot('r', { estopped: true, online: false })).status, 'E-STOPPED · offline');
  // A search still puts the robot it names first, whatever the order asked.
  assert.equal(pickerRows(fleet, '1', 'status')[0].name, 'robot1');
});

test('the line under a name: battery, mission and alerts when known, nothing otherwise', () => {
  assert.equal(detailsOf(robot('robot1')), '');
  assert.equal(
    detailsOf(robot('robot1', { battery: 80.6, mission: 'mission: step 2 of 3 (inspect spill)', alerts: 1 })),
    'battery 81 % · mission: step 2 of 3 (inspect spill) · 1 alert',
  );
  assert.equal(detailsOf(robot('robot1', { alerts: 3 })), '3 alerts');
});

test("a robot's facts from the fleet model: its status, its battery sensor in percent", () => {
  const entry = {
    description: {
      name: 'robot7',
      colour: '#fff',
      model: '',
      cameras: [],
      sensors: [],
      limits: /** @type {any} */ ({}),
    },
    pose: null,
    status: null,
    sensors: new Map(),
    nav: null,
  };
  assert.deepEqual(fleetFacts([entry], () => '', [])[0], {
    name: 'robot7',
    online: null,
    mode: null,
    estopped: false,
    battery: null,
    mission: '',
    alerts: 0,
  });
  const status = {
    identifier: 'robot7/status',
    online: true,
    age: 0.1,
    mode: 'navigating',
    goal: null,
    controller: null,
  };
  entry.status = /** @type {any} */ ({ ...status, estopped: true });
  entry.sensors.set('gas', {
    identifier: 'robot7/sensor',
    name: 'gas',
    value: 3,
    unit: 'ppm',
    warning: false,
    stamp: 0,
  });
  entry.sensors.set('battery', {
    identifier: 'robot7/sensor',
    name: 'battery',
    value: 64,
    unit: '%',
    warning: false,
    stamp: 0,
  });
  const alerts = [{ robot: 'robot7' }, { robot: null }, { robot: 'robot1' }, { robot: 'robot7' }];
  const progress = (/** @type {string} */ r) => (r === 'robot7' ? 'mission: step 1 of 2 (inspect valve_b)' : '');
  const [facts] = fleetFacts([/** @type {any} */ (entry)], progress, alerts);
  assert.equal(facts.mission, 'mission: step 1 of 2 (inspect valve_b)');
  assert.deepEqual([facts.mode, facts.estopped, facts.battery, facts.alerts], ['navigating', true, 64, 2]);
});
