// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { InspectionModel } from '../src/inspection_model.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

/** @param {Partial<import('../src/protocol.js').MissionMessage>} fields @returns {import('../src/protocol.js').MissionMessage} */
function mission(fields) {
  return {
    identifier: 'mission',
    id: 'm-1.robot1',
    name: 'Demo inspection',
    robot: 'robot1',
    state: 'running',
    current: 0,
    steps: [
      { kind: 'inspect', target: 'spill', x: null, y: null, yaw: null, seconds: null },
      { kind: 'dwell', target: null, x: null, y: null, yaw: null, seconds: 2 },
    ],
    reason: '',
    owner: 'c1',
    updated: 1,
    ...fields,
  };
}

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
    status: 'anomaly',
    note: 'gas 698.2 ppm (over 400 ppm)',
    source: 'rule',
    region: null,
    image: '/captures/ab.jpg',
    readings: { gas: 698.2 },
    created: 10,
    updated: 10,
    ...fields,
  };
}

test('missions are followed by state, and the operator is told of every change that matters', () => {
  const model = new InspectionModel();
  assert.deepEqual(model.apply(mission({})), []);
  assert.equal(model.progress('robot1'), 'mission: step 1 of 2 (inspect spill)');
  assert.deepEqual(model.apply(mission({ current: 1 })), []);
  assert.deepEqual(model.apply(mission({ current: 1, state: 'paused', reason: 'c2 takes over' })), [
    { text: "robot1's mission paused: c2 takes over", kind: 'warning' },
  ]);
  assert.equal(model.progress('robot1'), 'mission: step 2 of 2 (dwell) · paused: c2 takes over');
  assert.deepEqual(model.apply(mission({ current: 1, state: 'running' })), [
    { text: "robot1's mission running again", kind: 'info' },
  ]);
  assert.deepEqual(model.apply(mission({ current: 2, state: 'aborted', reason: 'emergency stop by c1' })), [
    { text: "robot1's mission aborted: emergency stop by c1", kind: 'error' },
  ]);
  assert.equal(model.active('robot1'), null);
  assert.equal(model.progress('robot1'), '');
});

test('findings are listed newest first, filtered, and an anomaly is announced once', () => {
  const model = new InspectionModel();
  assert.equal(model.apply(finding({}))[0].kind, 'warning');
  assert.deepEqual(model.apply(finding({ note: 'updated' })), []); // an update of a known finding: no new notice
  model.apply(finding({ id: 'f-2', status: 'ok', target: 'panels', robot: 'robot2', created: 20 }));
  assert.deepEqual(
    model.list().map((f) => f.id),
    ['f-2', 'f-1'],
  );
  assert.deepEqual(
    model.list({ status: 'anomaly' }).map((f) => f.id),
    ['f-1'],
  );
  assert.deepEqual(
    model.list({ robot: 'robot2' }).map((f) => f.id),
    ['f-2'],
  );
});

test('a page of the findings history joins the list quietly and says whether older ones remain', () => {
  const model = new InspectionModel();
  model.apply(finding({ id: 'f-9', created: 90 }));
  assert.equal(model.history, 'unknown');
  assert.equal(model.oldest(), 90);
  const older = [finding({ id: 'f-5', created: 50 }), finding({ id: 'f-4', created: 40 })];
  const told = model.apply({ identifier: 'findings', id: 'p1', findings: older, more: true });
  assert.deepEqual(told, []); // old anomalies are history, not news
  assert.equal(model.history, 'more');
  assert.equal(model.oldest(), 40);
  assert.deepEqual(
    model.list().map((f) => f.id),
    ['f-9', 'f-5', 'f-4'],
  );
  model.apply({ identifier: 'findings', id: 'p2', findings: [], more: false });
  assert.equal(model.history, 'all');
  model.reset();
  assert.equal(model.history, 'unknown');
  assert.equal(model.oldest(), null);
});

test('the sender asks for a page before the oldest finding, or the newest', () => {
  /** @type {any[]} */
  const sent = [];
  const sender = new CommandSender(
    /** @type {any} */ ({ send: (/** @type {any} */ m) => (sent.push(m), 1) }),
    () => {},
  );
  sender.findingsPage(40);
  sender.findingsPage(null);
  assert.deepEqual(
    sent.map(({ identifier, before }) => ({ identifier, before })),
    [
      { identifier: 'findings/page', before: 40 },
      { identifier: 'findings/page', before: undefined },
    ],
  );
});

test('the router hands inspection messages to the model and resets it on hello', () => {
  const inspection = new InspectionModel();
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands: new CommandSender({ send: () => null }, () => {}),
    inspection,
  });
  const targets = {
    identifier: /** @type {'targets'} */ ('targets'),
    targets: [{ id: 'spill', name: 'Spill', kind: 'gas', x: 1.8, y: 8.2, facing: null }],
  };
  assert.deepEqual(router.route(targets, 0), [{ type: 'inspection' }]);
  assert.equal(inspection.targets.get('spill')?.name, 'Spill');
  // Later changes come as deltas: a target added or replaced, another removed; the rest stays.
  const changed = {
    identifier: /** @type {'targets_changed'} */ ('targets_changed'),
    added: [
      { id: 'valve', name: 'Valve 12', kind: 'valve', x: 15.6, y: 7.6, facing: null },
      { id: 'spill', name: 'Drum 7', kind: 'gas', x: 1.8, y: 8.2, facing: null },
    ],
    removed: [],
  };
  assert.deepEqual(router.route(changed, 0), [{ type: 'inspection' }]);
  assert.deepEqual([...inspection.targets.keys()].sort(), ['spill', 'valve']);
  assert.equal(inspection.targets.get('spill')?.name, 'Drum 7');
  router.route({ ...changed, added: [], removed: ['valve'] }, 0);
  assert.deepEqual([...inspection.targets.keys()], ['spill']);
  const effects = router.route(finding({}), 0);
  assert.equal(effects[0].type, 'inspection');
  assert.equal(effects[1].type, 'notify');
  router.route(
    {
      identifier: 'region',
      id: 'r7',
      capture: 'c-1',
      outline: [
        [1, 2],
        [3, 4],
        [5, 6],
      ],
    },
    0,
  );
  assert.deepEqual(inspection.regions.get('r7'), [
    [1, 2],
    [3, 4],
    [5, 6],
  ]);
});

test("the sensor panel's status line carries the selected robot's mission progress", async () => {
  const { sensorPanel } = await import('../src/sensor_panel.js');
  const fleet = new FleetModel();
  const hello = JSON.parse(
    (await import('node:fs')).readFileSync(new URL('./fixtures/hello.json', import.meta.url), 'utf8'),
  );
  fleet.apply(hello);
  const model = new InspectionModel();
  model.apply(mission({}));
  const panel = sensorPanel(
    fleet,
    'robot1',
    new SensorHistory(),
    { text: 'connected', ok: true },
    0,
    model.progress('robot1'),
  );
  assert.match(panel.status, / · mission: step 1 of 2 \(inspect spill\)$/);
  assert.doesNotMatch(
    sensorPanel(fleet, 'robot2', new SensorHistory(), { text: '', ok: true }, 0, model.progress('robot2')).status,
    /mission/,
  );
});

/** @param {Partial<import('../src/protocol.js').AlertMessage>} fields @returns {import('../src/protocol.js').AlertMessage} */
function alert(fields) {
  return {
    identifier: 'alert',
    alert: 'a-1',
    kind: 'anomaly',
    robot: 'robot2',
    subject: 'f-1',
    text: 'Anomaly at Spill (robot2): gas 312.0 ppm (over 200 ppm)',
    severity: 'critical',
    raised: 10,
    acknowledged: null,
    ...fields,
  };
}

test('alerts are listed newest first until someone acknowledges them, and told once while new', () => {
  const inspection = new InspectionModel(() => 15);
  /** @type {any[]} */
  const sent = [];
  const sender = new CommandSender(
    /** @type {any} */ ({ send: (/** @type {any} */ m) => (sent.push(m), 1) }),
    () => {},
  );
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands: sender,
    inspection,
  });
  const raised = router.route(alert({}), 0);
  assert.deepEqual(raised, [
    { type: 'inspection' },
    {
      type: 'notify',
      text: 'Alert: Anomaly at Spill (robot2): gas 312.0 ppm (over 200 ppm)',
      kind: 'error',
      toast: true,
    },
  ]);
  assert.deepEqual(router.route(alert({}), 0), [{ type: 'inspection' }]); // the same alert again: no second notice
  inspection.apply(alert({ alert: 'a-2', kind: 'mission_aborted', severity: 'warning', raised: 20, text: 'Mission' }));
  assert.deepEqual(
    inspection.openAlerts().map((a) => a.alert),
    ['a-2', 'a-1'],
  );
  // This operator acknowledges one; the relay tells everyone, and it leaves the list (also of other operators).
  sender.alertAck('a-1');
  sender.alertAck('a-2', 'valve closed');
  assert.deepEqual(
    sent.map(({ identifier, alert, note }) => ({ identifier, alert, note })),
    [
      { identifier: 'alert/ack', alert: 'a-1', note: undefined },
      { identifier: 'alert/ack', alert: 'a-2', note: 'valve closed' },
    ],
  );
  assert.deepEqual(router.route(alert({ acknowledged: { by: 'Ana', at: 11, note: '' } }), 0), [{ type: 'inspection' }]);
  assert.deepEqual(
    inspection.openAlerts().map((a) => a.alert),
    ['a-2'],
  );
  inspection.reset(); // a new hello: the relay sends the open alerts again
  assert.equal(inspection.alerts.size, 0);
  inspection.wall = () => 10 + 121; // old news by now: listed, not told
  assert.deepEqual(router.route(alert({}), 0), [{ type: 'inspection' }]);
  assert.equal(inspection.alerts.size, 1);
});
