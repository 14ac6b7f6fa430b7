// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  draftOf,
  fieldOf,
  localTime,
  newDraft,
  parseLocal,
  ScheduleEditor,
  scheduleCommand,
  START_AHEAD,
  WEEKDAYS,
} from '../src/schedule_draft.js';
import { InspectionModel } from '../src/inspection_model.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

/** Mon 30 Nov 2026 08:00 UTC. */
const MONDAY_8 = Date.UTC(2026, 10, 30, 8) / 1000;

/**
 * A schedule as the relay's `schedules` message lists it.
 * @param {Partial<import('../src/protocol.js').ScheduleDescription>} fields
 * @returns {import('../src/protocol.js').ScheduleDescription}
 */
function listed(fields) {
  return {
    schedule: 'rounds',
    mission: { robot: 'robot1', steps: [{ inspect: 'spill' }, { inspect: 'leak' }] },
    start: MONDAY_8 + 0.25,
    repeat: 60,
    windows: [{ days: [...WEEKDAYS], hours: [0, 24] }],
    blackouts: [],
    priority: 0,
    on_busy: 'wait',
    owner: 'Tess',
    updated: MONDAY_8,
    next_run: MONDAY_8 + 60,
    last_run: null,
    state: 'scheduled',
    reason: '',
    ...fields,
  };
}

test('a time reads back as typed, to the second, in the browser’s zone; a bad one reads as none', () => {
  const t = MONDAY_8 + 3725; // 09:02:05 UTC
  assert.match(localTime(t), /^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:05$/);
  assert.equal(parseLocal(localTime(t)), t);
  assert.equal(parseLocal(localTime(t).slice(0, 16)), t - 5, 'without seconds: the minute');
  assert.equal(parseLocal(localTime(t + 0.9)), t, 'to the second');
  for (const bad of ['', 'tomorrow', '2026-02-30T08:00', '2026-11-30 08:00']) assert.equal(parseLocal(bad), null, bad);
});

test('a new form: a minute from now, hourly, every day all day, waiting for a busy robot', () => {
  const draft = newDraft(MONDAY_8);
  assert.equal(parseLocal(draft.start), MONDAY_8 + START_AHEAD);
  assert.deepEqual(draft.windows, [{ days: [...WEEKDAYS], first: '0', last: '24' }]);
  assert.equal(draft.repeat, '60');
  assert.equal(draft.onBusy, 'wait');
});

test('the form makes schedule/add: targets for a robot are its steps, for the fleet its targets', () => {
  const draft = {
    ...newDraft(MONDAY_8),
    name: ' rounds ',
    targets: ['spill', 'leak'],
    robot: 'robot1',
    repeat: '1.5',
    blackouts: [{ start: localTime(MONDAY_8 + 3600), end: localTime(MONDAY_8 + 7200) }],
    priority: '2',
    onBusy: /** @type {const} */ ('skip'),
  };
  draft.windows = [{ days: ['fri', 'mon'], first: '8', last: '17' }];
  const { command, problems } = scheduleCommand(draft, null);
  assert.deepEqual(problems, []);
  assert.deepEqual(command, {
    identifier: 'schedule/add',
    schedule: 'rounds',
    mission: { robot: 'robot1', steps: [{ inspect: 'spill' }, { inspect: 'leak' }] },
    start: MONDAY_8 + START_AHEAD,
    repeat: 90,
    windows: [{ days: ['mon', 'fri'], hours: [8, 17] }],
    blackouts: [{ start: MONDAY_8 + 3600, end: MONDAY_8 + 7200 }],
    priority: 2,
    on_busy: 'skip',
  });
  const fleet = scheduleCommand({ ...draft, robot: '', blackouts: [] }, null).command;
  assert.deepEqual(fleet && 'mission' in fleet && fleet.mission, { targets: ['spill', 'leak'] });
  assert.equal(fleet && 'blackouts' in fleet, false, 'no blackouts: none sent');
  const file = scheduleCommand({ ...draft, what: 'file', file: 'demo' }, null).command;
  assert.deepEqual(file && 'mission' in file && file.mission, { file: 'demo' });
});

test('the page refuses only what it cannot send; the rules are left to the relay, which names the field', () => {
  const empty = scheduleCommand({ ...newDraft(MONDAY_8), start: 'soon', repeat: '', priority: 'high' }, null);
  assert.equal(empty.command, null);
  assert.deepEqual(
    empty.problems.map((p) => p.field),
    ['schedule', 'mission', 'start', 'repeat', 'priority'],
  );
  // A repeat under a minute and a window without days are the relay's to refuse (relay/inspection/schedule_rules.py).
  const draft = { ...newDraft(MONDAY_8), name: 'quick', targets: ['spill'], repeat: '0.5' };
  draft.windows = [{ days: [], first: '17', last: '8' }];
  const { command } = scheduleCommand(draft, null);
  assert.ok(command && 'repeat' in command);
  assert.equal(command.repeat, 30);
  assert.deepEqual(command.windows, [{ days: [], hours: [17, 8] }]);
});

test('Edit fills the form from the list, and sends only what was changed', () => {
  const before = listed({ blackouts: [{ start: MONDAY_8 + 600, end: MONDAY_8 + 1200 }], priority: 3 });
  const draft = draftOf(before);
  assert.equal(draft.what, 'targets');
  assert.deepEqual([draft.robot, draft.targets, draft.repeat], ['robot1', ['spill', 'leak'], '1']);
  assert.deepEqual(scheduleCommand(draft, before), {
    command: null,
    problems: [{ field: 'schedule', text: 'nothing changed' }],
  });
  assert.deepEqual(scheduleCommand({ ...draft, repeat: '2' }, before).command, {
    identifier: 'schedule/update',
    schedule: 'rounds',
    repeat: 120,
  });
  assert.deepEqual(scheduleCommand({ ...draft, targets: ['leak'], onBusy: 'skip', blackouts: [] }, before).command, {
    identifier: 'schedule/update',
    schedule: 'rounds',
    mission: { robot: 'robot1', steps: [{ inspect: 'leak' }] },
    blackouts: [],
    on_busy: 'skip',
  });
  // A mission the form cannot show (a dwell step) is kept as it is, unless the operator picks another.
  const dwell = listed({ mission: { robot: 'robot3', steps: [{ inspect: 'leak' }, { dwell: 2 }], name: 'boiler' } });
  const kept = draftOf(dwell);
  assert.equal(kept.what, 'kept');
  assert.deepEqual(scheduleCommand({ ...kept, priority: '1' }, dwell).command, {
    identifier: 'schedule/update',
    schedule: 'rounds',
    priority: 1,
  });
  const replaced = scheduleCommand({ ...kept, what: 'file', file: 'demo' }, dwell).command;
  assert.deepEqual(replaced && 'mission' in replaced && replaced.mission, { file: 'demo', name: 'boiler' });
});

test('the field a relay refusal names', () => {
  const cases = [
    ['schedule/add: repeat must be at least 60 s, got 30.0', 'repeat'],
    ['schedule/add: field \'windows\' must be a list of 1 to 14 {"days": ...}; windows[0].days is not', 'windows'],
    ['schedule/add: windows[0]: hours must be 0 <= first < last <= 24, got 17-8', 'windows'],
    ['schedule/add: a schedule needs at least one window (days and hours)', 'windows'],
    ['schedule/add: unknown target(s) valve-9', 'mission'],
    ["schedule/add: field 'mission.targets' must be a list of 1 to 200 names", 'mission'],
    ["schedule/update: unknown robot 'robot9'", 'mission'],
    ['schedule/add: blackouts[0] must be a time range with start before end', 'blackouts'],
    ["schedule/add: schedule 'rounds' exists already", 'schedule'],
    ["schedule/add: field 'schedule' must be 1-64 letters, digits, _ or -", 'schedule'],
  ];
  for (const [message, field] of cases) assert.equal(fieldOf(message), field, message);
});

test('the editor: an error is kept with its field, an ack clears the form, a removed schedule ends its edit', () => {
  const model = new InspectionModel(() => MONDAY_8);
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands: new CommandSender({ send: () => null }, () => {}),
    inspection: model,
  });
  const editor = new ScheduleEditor(MONDAY_8);
  assert.equal(editor.open, false, 'closed until New schedule or Edit');
  editor.start(MONDAY_8 + 600);
  assert.equal(editor.open, true);
  assert.equal(parseLocal(editor.draft.start), MONDAY_8 + 600 + START_AHEAD, 'a minute from when it was opened');
  editor.draft = { ...editor.draft, name: 'quick', targets: ['spill'], repeat: '0.5' };
  const command = editor.submit();
  assert.ok(command);
  model.await('s-1');
  editor.sent('s-1', 'change', 'quick');
  assert.equal(editor.submit(), null, 'one at a time');
  assert.equal(editor.settle(model.settled, model.refusals, MONDAY_8), false, 'no answer yet');
  const message = 'schedule/add: repeat must be at least 60 s, got 30.0';
  router.route({ identifier: 'error', id: 's-1', code: 'bad_request', message }, 0);
  assert.equal(editor.settle(model.settled, model.refusals, MONDAY_8), true);
  assert.deepEqual([editor.error, editor.field, editor.pending], [message, 'repeat', null]);
  assert.equal(editor.draft.name, 'quick', 'what was typed stays, to be corrected');
  assert.equal(editor.open, true);

  editor.draft.repeat = '1';
  assert.ok(editor.submit());
  model.await('s-2');
  editor.sent('s-2', 'change', 'quick');
  assert.equal(editor.error, '');
  router.route({ identifier: 'ack', id: 's-2' }, 0);
  editor.settle(model.settled, model.refusals, MONDAY_8 + 5);
  assert.deepEqual([editor.draft.name, editor.open], ['', false], 'cleared and closed');
  assert.equal(parseLocal(editor.draft.start), MONDAY_8 + 5 + START_AHEAD);

  const rounds = listed({});
  editor.edit(rounds);
  editor.sync([rounds]);
  assert.equal(editor.before, rounds);
  editor.sync([]);
  assert.equal(editor.before, null);
  assert.deepEqual([editor.field, editor.draft.name], ['schedule', 'rounds'], 'kept, to be added again');
  // A new relay: the command awaiting its answer will get none.
  editor.sent('s-3', 'remove', 'rounds');
  editor.reset();
  assert.equal(editor.pending, null);
});
