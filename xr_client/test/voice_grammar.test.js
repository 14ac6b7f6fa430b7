// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { CONFIRM_MS, VoiceConfirm, describe, moves, parse, words } from '../src/voice_grammar.js';

/** The demo fleet's robots and rooms (scenes/facility.yaml), and two inspection targets. */
const VOCAB = {
  robots: ['robot1', 'robot2', 'robot3'],
  rooms: [
    { name: 'corridor', title: 'Corridor', bounds: [0, 0, 18, 3] },
    { name: 'chemical_storage', title: 'Chemical storage', bounds: [0, 3, 6, 10] },
    { name: 'power_distribution', title: 'Power distribution', bounds: [6, 3, 12, 10] },
    { name: 'plumbing', title: 'Plumbing', bounds: [12, 3, 18, 10] },
  ],
  targets: [
    { name: 'pressure gauge', x: 14.2, y: 8.5 },
    { name: 'valve_b', x: 3.1, y: 9.0 },
  ],
  selected: null,
};
const SELECTED = { ...VOCAB, selected: 'robot3' };

/** @param {string} text @param {typeof VOCAB} [vocab] */
function command(text, vocab = VOCAB) {
  const parsed = parse(text, vocab);
  assert.ok('command' in parsed, `"${text}" was refused: ${'refused' in parsed ? parsed.refused : ''}`);
  return parsed.command;
}

/** @param {string} text @param {typeof VOCAB} [vocab] */
function refusal(text, vocab = VOCAB) {
  const parsed = parse(text, vocab);
  assert.ok('refused' in parsed, `"${text}" was not refused: ${JSON.stringify(parsed)}`);
  assert.equal(parsed.heard, text.trim(), 'what was heard is always returned');
  return parsed.refused;
}

const GOTO = [
  ['robot two go to power distribution', 'robot2', 'power_distribution'],
  ['Robot 2, go to Power Distribution.', 'robot2', 'power_distribution'],
  ['robot2 go to power distribution', 'robot2', 'power_distribution'],
  ['robot to go to power distribution', 'robot2', 'power_distribution'], // how recognisers write "robot two"
  ['robot too go to the power distribution', 'robot2', 'power_distribution'],
  ['please send robot one to chemical storage', 'robot1', 'chemical_storage'],
  ['robot one drive to the chemical storage please', 'robot1', 'chemical_storage'],
  ['robot 3 navigate to plumbing', 'robot3', 'plumbing'],
  ['robot three, head to the corridor', 'robot3', 'corridor'],
  ['uh robot one um go to corridor', 'robot1', 'corridor'],
  ['robot one move to power-distribution', 'robot1', 'power_distribution'],
  ['ROBOT ONE GO TO PLUMBING', 'robot1', 'plumbing'],
  ['robot 1 go to the pressure gauge', 'robot1', 'pressure gauge'],
  ['robot two go to valve b', 'robot2', 'valve_b'],
  ['could you send robot three to chemical storage', 'robot3', 'chemical_storage'],
];

for (const [text, robot, place] of GOTO) {
  test(`goto: "${text}"`, () => {
    const c = command(text);
    assert.equal(c.kind, 'goto');
    if (c.kind !== 'goto') return;
    assert.equal(c.robot, robot);
    assert.equal(c.place.name, place);
    assert.ok(moves(c), 'a goal waits for a confirmation');
  });
}

test('a room sends the robot to its middle; a target to its own point', () => {
  const room = command('robot two go to power distribution');
  assert.ok(
    room.kind === 'goto' && room.place.kind === 'room' && room.place.x === 9 && room.place.y === 6.5,
    JSON.stringify(room),
  );
  const target = command('robot one go to the pressure gauge');
  assert.ok(
    target.kind === 'goto' && target.place.kind === 'target' && target.place.x === 14.2 && target.place.y === 8.5,
  );
});

test('"go to <place>" without a robot takes the selected one, or asks which', () => {
  const c = command('go to plumbing', SELECTED);
  assert.ok(c.kind === 'goto' && c.robot === 'robot3');
  assert.match(refusal('go to plumbing'), /which robot\? say "robot one go to plumbing"/);
});

const STOP_ALL = [
  'stop all',
  'Stop all!',
  'stop all robots',
  'emergency stop',
  'e-stop',
  'estop',
  'stop everything',
  'everyone stop',
  'halt all',
  'STOP THE FLEET',
  'please stop all robots now',
  'emergency',
];
for (const text of STOP_ALL) {
  test(`stop all: "${text}"`, () => {
    assert.deepEqual(command(text), { kind: 'stop_all' });
    assert.equal(moves(command(text)), false);
  });
}

test('stop names a robot, or the selected one, or (none selected) all of them', () => {
  assert.deepEqual(command('robot two stop'), { kind: 'stop', robot: 'robot2' });
  assert.deepEqual(command('stop robot 1'), { kind: 'stop', robot: 'robot1' });
  assert.deepEqual(command('halt robot three'), { kind: 'stop', robot: 'robot3' });
  assert.deepEqual(command('stop', SELECTED), { kind: 'stop', robot: 'robot3' });
  assert.deepEqual(command('stop'), { kind: 'stop_all' });
  // A stop is never refused: a robot the fleet does not have stops them all.
  assert.deepEqual(command('stop robot nine'), { kind: 'stop_all' });
  // A phrase that holds a stop and a goal stops.
  assert.deepEqual(command('robot two stop go to plumbing'), { kind: 'stop', robot: 'robot2' });
});

test('stop names a group: a team or a room with robots in it; a robot named is that robot', () => {
  const groups = {
    ...SELECTED,
    groups: [
      { label: 'North crew', robots: ['robot1', 'robot2'] },
      { label: 'Corridor', robots: ['robot1', 'robot2', 'robot3'] },
      { label: 'Chemical storage', robots: ['robot3'] },
    ],
  };
  const north = { kind: 'stop_group', group: 'North crew', robots: ['robot1', 'robot2'] };
  assert.deepEqual(command('stop north crew', groups), north);
  assert.deepEqual(command('stop team North Crew now', groups), north);
  assert.deepEqual(command('halt the chemical storage', groups), {
    kind: 'stop_group',
    group: 'Chemical storage',
    robots: ['robot3'],
  });
  assert.deepEqual(command('stop robot one in the corridor', groups), { kind: 'stop', robot: 'robot1' });
  assert.deepEqual(command('stop', groups), { kind: 'stop', robot: 'robot3' }, 'no group named: the selected robot');
  assert.deepEqual(command('stop all', groups), { kind: 'stop_all' });
  const group = command('stop north crew', groups);
  assert.equal(describe(group), 'stop North crew');
  assert.equal(moves(group), false);
  // A stop never waits for a confirmation, a group's neither.
  const v = new VoiceConfirm();
  assert.deepEqual(v.hear(parse('stop north crew', groups), 0), [{ type: 'run', command: north }]);
});

test('select, snapshot, views, teleport, missions', () => {
  assert.deepEqual(command('robot two'), { kind: 'select', robot: 'robot2' });
  assert.deepEqual(command('select robot 3'), { kind: 'select', robot: 'robot3' });
  assert.deepEqual(command('switch to robot one'), { kind: 'select', robot: 'robot1' });
  assert.deepEqual(command('take a snapshot'), { kind: 'snapshot', robot: null });
  assert.deepEqual(command('snapshot', SELECTED), { kind: 'snapshot', robot: 'robot3' });
  assert.deepEqual(command('take a picture with robot two'), { kind: 'snapshot', robot: 'robot2' });
  assert.deepEqual(command('point of view'), { kind: 'view', view: 'pov' });
  assert.deepEqual(command('switch to robot view'), { kind: 'view', view: 'pov' });
  assert.deepEqual(command('free roam'), { kind: 'view', view: 'free_roam' });
  assert.deepEqual(command('show the overview'), { kind: 'view', view: 'free_roam' });
  assert.deepEqual(command('teleport to robot two'), { kind: 'teleport', robot: 'robot2' });
  assert.deepEqual(command('take me to robot 3'), { kind: 'teleport', robot: 'robot3' });
  assert.deepEqual(command('start the mission'), { kind: 'mission', action: 'start' });
  assert.deepEqual(command('begin mission'), { kind: 'mission', action: 'start' });
  assert.deepEqual(command('pause mission'), { kind: 'mission', action: 'pause' });
  assert.deepEqual(command('resume the mission'), { kind: 'mission', action: 'resume' });
  assert.deepEqual(command('abort mission'), { kind: 'mission', action: 'abort' });
  assert.deepEqual(
    command('stop the mission'),
    { kind: 'mission', action: 'abort' },
    '"stop" with "mission" ends the mission',
  );
  assert.deepEqual(command('confirm'), { kind: 'confirm' });
  assert.deepEqual(command('yes'), { kind: 'confirm' });
  assert.deepEqual(command('Go.'), { kind: 'confirm' });
  assert.deepEqual(command('cancel'), { kind: 'cancel' });
  assert.deepEqual(command('never mind'), { kind: 'cancel' });
});

test('refusals say why: an unknown robot, an unknown room, a missing teleport target, gibberish, silence', () => {
  assert.match(refusal('robot seven go to plumbing'), /no robot 7 in this fleet \(robot1, robot2, robot3\)/);
  assert.match(refusal('robot 9'), /no robot 9/);
  assert.match(
    refusal('robot one go to the kitchen'),
    /no room or target called "kitchen" \(rooms: corridor, chemical storage, power distribution, plumbing\)/,
  );
  assert.match(refusal('teleport'), /to which robot/);
  assert.match(refusal('make me a sandwich'), /not a command: "make me a sandwich"/);
  assert.match(refusal('   '), /nothing was heard/);
  assert.match(refusal('mission'), /start, pause, resume or abort/);
});

test('words: case, punctuation, digits glued to names', () => {
  assert.deepEqual(words('Robot2, GO to power_distribution!'), ['robot', '2', 'go', 'to', 'power', 'distribution']);
});

test('motion waits for a confirmation; stops act at once and drop what waited; confirmations lapse', () => {
  const v = new VoiceConfirm();
  const ask = v.hear(parse('robot two go to power distribution', VOCAB), 1000);
  assert.equal(ask.length, 1);
  assert.equal(ask[0].type, 'ask');
  assert.equal(describe(/** @type {any} */ (ask[0]).command), 'robot2 go to Power distribution');
  assert.deepEqual(
    v.hear(parse('confirm', VOCAB), 2000).map((e) => e.type),
    ['run'],
    'confirmed in time',
  );
  assert.deepEqual(v.hear(parse('confirm', VOCAB), 2100), [{ type: 'say', text: 'nothing to confirm' }]);

  v.hear(parse('robot one go to plumbing', VOCAB), 3000);
  assert.deepEqual(v.hear(parse('stop all', VOCAB), 3100), [{ type: 'run', command: { kind: 'stop_all' } }]);
  assert.equal(v.pending, null, 'a stop overrides the goal that waited');
  assert.deepEqual(v.confirm(3200), [{ type: 'say', text: 'nothing to confirm' }], 'so a late pinch sends nothing');

  v.hear(parse('start mission', VOCAB), 4000);
  assert.deepEqual(v.confirm(4000 + CONFIRM_MS + 1), [{ type: 'say', text: 'nothing to confirm' }], 'lapsed');
  // What lapsed is told once (the page says so), and a command confirmed or replaced in time never lapses.
  v.hear(parse('robot one go to plumbing', VOCAB), 4500);
  assert.equal(v.expire(4500 + CONFIRM_MS), null, 'not yet');
  assert.equal(describe(/** @type {any} */ (v.expire(4500 + CONFIRM_MS + 1))), 'robot1 go to Plumbing');
  assert.equal(v.expire(4500 + CONFIRM_MS + 2), null, 'once');
  v.hear(parse('robot one go to plumbing', VOCAB), 5000);
  assert.deepEqual(v.hear(parse('cancel', VOCAB), 5100), [{ type: 'say', text: 'cancelled: robot1 go to Plumbing' }]);
  assert.deepEqual(
    v.hear(parse('pause mission', VOCAB), 5200).map((e) => e.type),
    ['run'],
    'a pause is a stop: at once',
  );
  assert.deepEqual(
    v.hear(parse('robot two', VOCAB), 5300).map((e) => e.type),
    ['run'],
    'selecting moves nothing',
  );
  const refused = v.hear(parse('robot seven go to plumbing', VOCAB), 5400);
  assert.deepEqual(refused, [
    { type: 'say', text: 'heard "robot seven go to plumbing": no robot 7 in this fleet (robot1, robot2, robot3)' },
  ]);
});

test('in a fleet of a hundred robots named robot1..robot100, "select robot 17" is robot17, not robot1 or robot100', () => {
  const robots = Array.from({ length: 100 }, (_, i) => `robot${i + 1}`);
  const fleet = { ...VOCAB, robots };
  for (const [text, robot] of [
    ['select robot 17', 'robot17'],
    ['robot seventeen', 'robot17'],
    ['select robot 1', 'robot1'],
    ['switch to robot 73', 'robot73'],
    ['robot 100', 'robot100'],
    ['Robot 10.', 'robot10'],
    ['select robot seventy three', 'robot73'],
    ['robot twenty one', 'robot21'],
    ['robot twenty', 'robot20'],
    ['robot thirty', 'robot30'],
    ['switch to robot one hundred', 'robot100'],
    ['robot a hundred', 'robot100'],
  ]) {
    const c = command(text, fleet);
    assert.ok(c.kind === 'select' && c.robot === robot, `${text}: ${JSON.stringify(c)}`);
  }
  const stop = command('stop robot 99', fleet);
  assert.ok(stop.kind === 'stop' && stop.robot === 'robot99');
  const goal = command('robot ninety nine go to plumbing', fleet);
  assert.ok(goal.kind === 'goto' && goal.robot === 'robot99');
  assert.match(refusal('select robot 101', fleet), /robot 101/);
});
