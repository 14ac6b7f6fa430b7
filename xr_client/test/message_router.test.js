// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

/** A hello the relay really sent (tests/test_schema.py checks that the fixture keeps the relay's shape). */
const HELLO = JSON.parse(readFileSync(new URL('./fixtures/hello.json', import.meta.url), 'utf8'));

function setUp() {
  /** @type {Record<string, unknown>[]} */
  const sent = [];
  /** @type {string[]} */
  const notSent = [];
  let next = 1;
  const link = {
    send: (/** @type {Record<string, unknown>} */ m, withId = true) => (sent.push(m), withId ? `r${next++}` : ''),
  };
  const commands = new CommandSender(link, (text) => notSent.push(text));
  const fleet = new FleetModel();
  const goals = new GoalTracker();
  const history = new SensorHistory();
  const router = new MessageRouter({ fleet, goals, history, commands });
  return { router, fleet, goals, history, commands, sent, notSent };
}

test('hello builds the fleet and asks for robot views once per distinct fleet', () => {
  const { router, fleet } = setUp();
  assert.deepEqual(router.route(HELLO, 0), [
    { type: 'fleet', rebuild: true },
    { type: 'estop_state', latched: [] },
  ]);
  assert.deepEqual([...fleet.robots.keys()], ['robot1', 'robot2', 'robot3']);
  assert.equal(fleet.clientId, 'c1-abc123');
  const yaw = HELLO.state.robot1.pose.yaw; // a quarter turn, as the relay rounds it
  assert.ok(Math.abs(yaw - Math.PI / 2) < 1e-5);
  assert.deepEqual(fleet.robot('robot1')?.pose, { x: 3, y: 1.5, yaw, stamp: 1700000000.5 });
  assert.equal(fleet.camera('robot2')?.identifier, 'robot2/camera/front');
  // The pose in hello seeds the smoother, so the robot is drawn where it is at once.
  assert.deepEqual(router.smoothers.get('robot1')?.sample(0), { x: 3, y: 1.5, yaw });
  // A reconnect to the same relay keeps the views (and their loaded models).
  assert.deepEqual(router.route({ ...HELLO, client_id: 'c2-def456' }, 10)[0], { type: 'fleet', rebuild: false });
  assert.equal(fleet.clientId, 'c2-def456');
});

test('poses, statuses and sensors update the models; a warning notifies once', () => {
  const { router, fleet, history } = setUp();
  router.route(HELLO, 0);
  const pose = {
    identifier: 'robot2/pose',
    stamp: 2,
    frame: 'map',
    x: 9,
    y: 4,
    z: 0,
    qx: 0,
    qy: 0,
    qz: 0,
    qw: 1,
    yaw: 0,
  };
  assert.deepEqual(router.route(pose, 100), []);
  assert.deepEqual(fleet.robot('robot2')?.pose, { x: 9, y: 4, yaw: 0, stamp: 2 });
  const status = {
    identifier: 'robot2/status',
    online: true,
    age: 0.01,
    mode: /** @type {const} */ ('navigating'),
    goal: { x: 3, y: 6, yaw: null },
    controller: 'c1-abc123',
    estopped: false,
  };
  assert.deepEqual(router.route(status, 100), [
    { type: 'goal_state', robot: 'robot2', active: true },
    { type: 'estop_state', latched: [] },
  ]);
  const gas = { identifier: 'robot1/sensor', name: 'gas', value: 512.3, unit: 'ppm', warning: true, stamp: 3 };
  const effects = router.route(gas, 200);
  assert.deepEqual(effects[1], { type: 'sensor_warning', robot: 'robot1' });
  assert.equal(
    effects[0].type === 'notify' && effects[0].text,
    'WARNING robot1: gas crossed over 400 ppm (512.3 ppm then)',
  );
  assert.deepEqual(router.route({ ...gas, value: 530 }, 300), [], 'a warning that holds does not notify again');
  assert.equal(history.robotWarning('robot1'), true);
  assert.deepEqual(router.route({ ...pose, identifier: 'robot9/pose' }, 300), [], 'unknown robots are ignored');
});

test('an estop stops local teleop and says who pressed it', () => {
  const { router } = setUp();
  router.route(HELLO, 0);
  const effects = router.route({ identifier: 'estop', robots: ['robot1', 'robot3'], by: 'c1-abc123' }, 5);
  assert.deepEqual(effects, [
    { type: 'stop_teleop' },
    { type: 'notify', text: 'EMERGENCY STOP: robot1, robot3 (by you)', kind: 'error', toast: true },
    { type: 'estop_state', latched: [] }, // an estop without `latched` (a relay from before the latch) latches nothing
  ]);
});

test('a latched estop is shown until an operator resets it; a reset stops nothing locally', () => {
  const { router, commands, sent } = setUp();
  router.route(HELLO, 0);
  const status = {
    identifier: 'robot1/status',
    online: true,
    age: 0.01,
    mode: /** @type {const} */ ('idle'),
    goal: null,
    controller: null,
    estopped: false,
  };
  for (const robot of ['robot1', 'robot2', 'robot3']) router.route({ ...status, identifier: `${robot}/status` }, 1);
  // The latch shows with the estop message itself, before the statuses that follow it.
  const latched = router.route(
    { identifier: 'estop', robots: ['robot1', 'robot2', 'robot3'], by: 'c9-ffffff', latched: true },
    1,
  );
  assert.equal(latched[0].type, 'stop_teleop');
  assert.deepEqual(latched.at(-1), { type: 'estop_state', latched: ['robot1', 'robot2', 'robot3'] });
  assert.deepEqual(router.route({ ...status, estopped: true }, 2).at(-1), {
    type: 'estop_state',
    latched: ['robot1', 'robot2', 'robot3'],
  });
  assert.deepEqual(router.route({ identifier: 'estop', robots: ['robot1'], by: 'c1-abc123', latched: false }, 3), [
    { type: 'notify', text: 'E-STOP reset: robot1 (by you)', kind: 'info', toast: true },
    { type: 'estop_state', latched: ['robot2', 'robot3'] },
  ]);
  assert.deepEqual(
    [...router.estopBy],
    [
      ['robot2', 'c9-ffffff'],
      ['robot3', 'c9-ffffff'],
    ],
  );
  assert.deepEqual(router.route({ ...status, estopped: false }, 4).at(-1), {
    type: 'estop_state',
    latched: ['robot2', 'robot3'],
  });
  commands.estopReset();
  assert.deepEqual(sent.at(-1), { identifier: 'estop', action: 'reset' });
});

test('losing a robot to another operator stops teleop; an expiry only informs', () => {
  const { router } = setUp();
  router.route(HELLO, 0);
  const taken = {
    identifier: 'robot1/lease',
    holder: 'c9-ffffff',
    previous: 'c1-abc123',
    reason: /** @type {const} */ ('taken_over'),
  };
  assert.deepEqual(router.route(taken, 1), [
    { type: 'stop_teleop' },
    { type: 'notify', text: 'robot1 was taken over by c9-ffffff', kind: 'error', toast: true },
    { type: 'cue', kind: 'lease_lost', robot: 'robot1' },
  ]);
  const expired = {
    identifier: 'robot1/lease',
    holder: null,
    previous: 'c1-abc123',
    reason: /** @type {const} */ ('expired'),
  };
  assert.equal(router.route(expired, 2)[0].type, 'notify');
  const others = {
    identifier: 'robot2/lease',
    holder: 'c9-ffffff',
    previous: null,
    reason: /** @type {const} */ ('acquired'),
  };
  assert.deepEqual(router.route(others, 3), []);
  // The goal lost with the robot is not told again a moment later (it would replace "taken over by ..."); once the
  // next goal has started, a cancellation is told again; a robot not taken is told at once.
  const cancelled = {
    identifier: 'robot1/nav',
    outcome: /** @type {const} */ ('cancelled'),
    goal: { x: 6, y: 2, yaw: null },
    message: '',
  };
  assert.deepEqual(router.route(cancelled, 40), []);
  assert.deepEqual(router.route({ ...cancelled, outcome: 'started' }, 41), []);
  assert.equal(router.route(cancelled, 42)[0].type, 'nav');
  assert.equal(router.route({ ...cancelled, identifier: 'robot2/nav' }, 43)[0].type, 'nav');
});

test('a leased refusal offers a take-over; snapshot replies settle their requests', () => {
  const { router, commands, sent } = setUp();
  router.route(HELLO, 0);
  const id = commands.snapshot('robot1', 'front');
  assert.equal(id, 'r1');
  assert.deepEqual(sent[0], { identifier: 'robot1/snapshot', camera: 'front' });
  const refusal = {
    identifier: /** @type {const} */ ('error'),
    id: 'r1',
    code: 'no_camera',
    message: "robot1/snapshot: camera 'front' has produced no image yet",
  };
  const effects = router.route(refusal, 1);
  assert.deepEqual(effects, [{ type: 'notify', text: `no_camera: ${refusal.message}`, kind: 'error', toast: true }]);
  assert.equal(commands.snapshots.failed, 1);
  assert.equal(commands.noImageYet, true);

  const leased = {
    identifier: /** @type {const} */ ('error'),
    id: 'r7',
    code: 'leased',
    message: 'robot2/goal_pose: robot2 is controlled by c9-ffffff; send robot2/lease with force: true to take over',
  };
  assert.deepEqual(router.route(leased, 2)[0], {
    type: 'offer_takeover',
    robot: 'robot2',
    text: leased.message,
    goal: null,
  });
  // A refused goal comes back with the offer: accepting sends it once the robot is taken.
  const goal = { x: 4, y: 6, yaw: null };
  router.goals.sent('robot2', goal, 'r8', 3);
  assert.deepEqual(router.route({ ...leased, id: 'r8' }, 4)[0], {
    type: 'offer_takeover',
    robot: 'robot2',
    text: leased.message,
    goal,
  });
  // Names: the roster replaces ids in what the operator reads.
  assert.deepEqual(router.route({ identifier: 'operators', names: { 'c9-ffffff': 'Ana' } }, 5), [{ type: 'names' }]);
  const taken = {
    identifier: 'robot1/lease',
    holder: 'c9-ffffff',
    previous: 'c1-abc123',
    reason: /** @type {const} */ ('taken_over'),
  };
  assert.equal(/** @type {any} */ (router.route(taken, 6)[1]).text, 'robot1 was taken over by Ana');
  commands.takeOver('robot2');
  assert.deepEqual(sent.at(-1), { identifier: 'robot2/lease', action: 'acquire', force: true });
});

test('a goal error is shown at its marker instead of as a toast', () => {
  const { router, commands, goals } = setUp();
  router.route(HELLO, 0);
  const id = commands.goal('robot1', { x: 40.123456, y: 2, yaw: null });
  assert.ok(id);
  goals.sent('robot1', { x: 40, y: 2, yaw: null }, id, 0);
  const effects = router.route(
    { identifier: 'error', id, code: 'out_of_bounds', message: 'robot1/goal_pose: (40.00, 2.00) is outside the map' },
    10,
  );
  assert.deepEqual(effects, [
    {
      type: 'notify',
      text: 'out_of_bounds: robot1/goal_pose: (40.00, 2.00) is outside the map',
      kind: 'error',
      toast: false,
    },
  ]);
});

test('the relay built a model: the view is rebuilt once; scans go to their robot', () => {
  const { router, fleet } = setUp();
  router.route(HELLO, 0);
  const model = { identifier: 'robot3/model', url: '/scenes/generated/robot-robot3-abc.glb' };
  assert.deepEqual(router.route(model, 1), [{ type: 'model', robot: 'robot3' }]);
  assert.equal(fleet.robot('robot3')?.description.model, model.url);
  assert.deepEqual(router.route(model, 2), [], 'the same model again changes nothing');
  const scan = {
    identifier: 'robot1/scan',
    stamp: 1,
    frame: 'robot1/base_scan',
    angle_min: 0,
    angle_increment: 0.1,
    range_max: 8,
    ranges: [1.5, null],
  };
  assert.deepEqual(router.route(scan, 3), [{ type: 'scan', robot: 'robot1', scan }]);
});

test('commands carry the generated identifiers; nothing is queued while disconnected', () => {
  /** @type {string[]} */
  const notSent = [];
  const commands = new CommandSender({ send: () => null }, (text) => notSent.push(text));
  assert.equal(commands.estop(), null);
  assert.deepEqual(notSent, ['not connected: estop not sent', 'not connected: E-STOP NOT DELIVERED']);
  commands.twist({ robot: 'robot1', linear: 0.2, angular: 0 });
  assert.equal(commands.counts.cmdVel, 0);
});

test('a plan is kept while the goal lasts; the outcome is told in words, and only the operator who cares hears it', () => {
  const { router } = setUp();
  router.route(HELLO, 0);
  assert.deepEqual(
    router.route(
      {
        identifier: 'robot1/path',
        points: [
          [3, 1.5],
          [3, 6],
        ],
      },
      1,
    ),
    [],
  );
  assert.deepEqual(router.paths.get('robot1'), [
    [3, 1.5],
    [3, 6],
  ]);
  assert.deepEqual(
    router.route({ identifier: 'robot1/nav', outcome: 'started', goal: { x: 3, y: 6, yaw: null }, message: '' }, 2),
    [],
  );
  const reached = router.route(
    { identifier: 'robot1/nav', outcome: 'reached', goal: { x: 3, y: 6, yaw: null }, message: '' },
    3,
  );
  assert.deepEqual(reached, [
    { type: 'nav', robot: 'robot1', text: 'robot1 reached its goal (3.0, 6.0)', kind: 'info', mine: false },
  ]);
  assert.equal(router.paths.has('robot1'), false, 'the path goes with the goal');
  const failed = router.route(
    { identifier: 'robot1/nav', outcome: 'failed', goal: { x: 3, y: 6, yaw: null }, message: 'blocked for 30 s' },
    4,
  );
  assert.equal(/** @type {any} */ (failed[0]).text, 'robot1 aborted its goal (3.0, 6.0): blocked for 30 s');
  const cancelled = router.route(
    { identifier: 'robot1/nav', outcome: 'cancelled', goal: null, message: 'cancelled' },
    5,
  );
  assert.deepEqual(cancelled, [
    { type: 'nav', robot: 'robot1', text: "robot1's goal cancelled", kind: 'warning', mine: false },
  ]);
  assert.deepEqual(
    router.route(
      {
        identifier: 'robot9/path',
        points: [
          [0, 0],
          [1, 1],
        ],
      },
      6,
    ),
    [],
  );
  assert.equal(router.paths.has('robot9'), false, 'an unknown robot has no path');
  router.route(
    {
      identifier: 'robot2/path',
      points: [
        [9, 1.5],
        [9, 6],
      ],
    },
    7,
  );
  router.route(HELLO, 8);
  assert.equal(router.paths.size, 0, 'a new relay: paths come again with the next plans');
});
