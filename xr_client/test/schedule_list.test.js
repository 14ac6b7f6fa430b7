// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { InspectionModel } from '../src/inspection_model.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';
import { missionWords, scheduleRows } from '../src/schedule_list.js';

/** Mon 30 Nov 2026 08:00 UTC. */
const MONDAY_8 = Date.UTC(2026, 10, 30, 8) / 1000;

/**
 * A schedule as the relay's `schedules` message carries it.
 * @param {Partial<import('../src/protocol.js').ScheduleDescription>} fields
 * @returns {import('../src/protocol.js').ScheduleDescription}
 */
function schedule(fields) {
  return {
    schedule: 'nightly',
    mission: { targets: ['spill', 'leak'], name: 'rounds' },
    start: MONDAY_8,
    repeat: 3600,
    windows: [{ days: ['mon', 'tue', 'wed', 'thu', 'fri'], hours: [8, 17] }],
    blackouts: [],
    priority: 0,
    on_busy: 'wait',
    owner: 'Ana',
    updated: MONDAY_8 - 600,
    next_run: MONDAY_8 + 3600,
    last_run: { slot: MONDAY_8, t: MONDAY_8 + 0.8, outcome: 'started', mission: 'm-1.robot1', reason: '' },
    state: 'running',
    reason: '',
    ...fields,
  };
}

test('each schedule is a row: what it runs, its next and last run, its state, by name', () => {
  const rows = scheduleRows(
    [
      schedule({}),
      schedule({
        schedule: 'boiler',
        mission: { robot: 'robot3', steps: [{ inspect: 'leak' }, { dwell: 2 }] },
        next_run: null,
        last_run: {
          slot: MONDAY_8,
          t: MONDAY_8 + 3601,
          outcome: 'missed',
          mission: null,
          reason: 'the relay was not running',
        },
        state: 'over',
      }),
      schedule({
        schedule: 'panels',
        mission: { file: 'demo' },
        state: 'waiting',
        reason: 'robot2 is emergency-stopped',
      }),
    ],
    'UTC',
  );
  assert.deepEqual(rows, [
    {
      name: 'boiler',
      what: '2 steps for robot3',
      next: 'none',
      last: 'missed Mon 30 Nov 08:00: the relay was not running',
      state: 'over',
      tone: 'warning',
    },
    {
      name: 'nightly',
      what: 'rounds: spill, leak (the fleet)',
      next: 'Mon 30 Nov 09:00',
      last: 'started Mon 30 Nov 08:00',
      state: 'running',
      tone: 'ok',
    },
    {
      name: 'panels',
      what: 'mission file demo',
      next: 'Mon 30 Nov 09:00',
      last: 'started Mon 30 Nov 08:00',
      state: 'waiting: robot2 is emergency-stopped',
      tone: 'warning',
    },
  ]);
  assert.equal(missionWords({ robot: 'robot1', steps: [{ dwell: 1 }] }), '1 step for robot1');
});

test('the schedules message replaces the list, and a new relay clears it', () => {
  const inspection = new InspectionModel(() => MONDAY_8);
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands: new CommandSender({ send: () => null }, () => {}),
    inspection,
  });
  const before = inspection.version;
  const effects = router.route({ identifier: 'schedules', schedules: [schedule({})] }, 0);
  assert.deepEqual(effects, [{ type: 'inspection' }]);
  assert.deepEqual(
    inspection.schedules.map((s) => s.schedule),
    ['nightly'],
  );
  assert.ok(inspection.version > before);
  router.route({ identifier: 'schedules', schedules: [] }, 0);
  assert.deepEqual(inspection.schedules, []);
  inspection.apply({ identifier: 'schedules', schedules: [schedule({})] });
  inspection.reset();
  assert.deepEqual(inspection.schedules, []);
});
