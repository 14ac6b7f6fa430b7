// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { SUS_ITEMS, StudyModel, TLX_SCALES, clockText, conditionEffect, probeQuestion } from '../src/study_model.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

/**
 * A `study` message as the relay sends it (relay/study/wire.py study_message).
 * @param {Partial<import('../src/protocol.js').StudyMessage>} fields
 * @returns {import('../src/protocol.js').StudyMessage}
 */
function study(fields) {
  return {
    identifier: 'study',
    study: 'drive-study',
    phase: 'ready',
    participants: ['P01', 'P02'],
    participant: 'P01',
    condition: 'desktop',
    settings: { view: 'desktop', sound: 'off' },
    task: 'reach-storage',
    instruction: 'Send robot1 into chemical storage.',
    time_limit: 120,
    elapsed: 0,
    questionnaire: null,
    probe: null,
    done: 0,
    total: 2,
    ...fields,
  };
}

test('the router hands the study message to the study model, whose effect redraws the panel', () => {
  const link = { send: () => 'x1' };
  const router = new MessageRouter({
    fleet: new FleetModel(),
    goals: new GoalTracker(),
    history: new SensorHistory(),
    commands: new CommandSender(link, () => {}),
  });
  assert.deepEqual(router.route(study({ phase: 'waiting', participant: null }), 1000), [{ type: 'study' }]);
  assert.equal(router.study.message?.phase, 'waiting');
  assert.equal(router.study.participant, 'P01'); // the first participant, until one is picked
  router.study.choose('P02');
  assert.deepEqual(router.study.join(), { identifier: 'study/join', participant: 'P02' });
  // A participant picked stays picked while the study has them, whoever the relay says joined.
  router.route(study({ participant: 'P01' }), 2000);
  assert.equal(router.study.participant, 'P02');
});

test("a condition's settings are taken as it starts: the sound set, the view and the input asked of the participant", () => {
  const model = new StudyModel();
  assert.deepEqual(model.apply(study({ phase: 'waiting', participant: null, condition: null, settings: {} }), 0), [
    { type: 'study' },
  ]);
  // P01 joins under `desktop` (sound off): the page mutes, and the participant is asked to stay at the desktop.
  const joined = model.apply(study({}), 1000);
  assert.deepEqual(joined[1], { type: 'condition', muted: true, ask: 'Condition desktop: stay at the desktop' });
  // The same condition's next message (its task running) changes nothing.
  assert.deepEqual(model.apply(study({ phase: 'task' }), 2000), [{ type: 'study' }]);
  // The next condition: the headset and the hands, sound as it is.
  const next = model.apply(study({ condition: 'headset', settings: { view: 'headset', input: 'hands' } }), 3000);
  assert.deepEqual(next[1], {
    type: 'condition',
    muted: null,
    ask: 'Condition headset: put on the headset (Enter VR), use your hands, controllers down',
  });
  assert.deepEqual(conditionEffect('quiet', { sound: 'on' }), { type: 'condition', muted: false, ask: '' });
});

test('a task counts its time left on the page clock from the relay elapsed, and says when it ends', () => {
  const model = new StudyModel();
  model.apply(study({}), 0);
  assert.equal(model.timeLeft(5000), null); // not running: nothing counts
  assert.deepEqual(model.start(), { identifier: 'study/start' });
  model.apply(study({ phase: 'task', elapsed: 10 }), 1000);
  assert.equal(model.start(), null); // only from an instruction
  assert.equal(model.timeLeft(1000), 110);
  assert.equal(model.timeLeft(31_000), 80);
  assert.equal(model.timeLeft(1_000_000), 0);
  assert.equal(clockText(80), '1:20');
  assert.equal(clockText(0.2), '0:01');
  const effects = model.apply(study({ phase: 'questions', questionnaire: 'tlx', elapsed: 42.5 }), 40_000);
  assert.deepEqual(effects[0], { type: 'study' });
  assert.equal(effects[1].type, 'notify');
  assert.equal(model.timeLeft(40_000), null);
});

test('the TLX is sent as six scales snapped to steps of 5, starting in the middle', () => {
  const model = new StudyModel();
  model.apply(study({ phase: 'questions', questionnaire: 'tlx' }), 0);
  assert.equal(TLX_SCALES.length, 6);
  assert.deepEqual(model.tlx, [50, 50, 50, 50, 50, 50]);
  model.setTlx(0, 42);
  model.setTlx(5, 130);
  model.setTlx(9, 10); // no such scale: ignored
  assert.deepEqual(model.answer(), {
    command: { identifier: 'study/answer', questionnaire: 'tlx', answers: [40, 50, 50, 50, 50, 100] },
  });
});

test('the SUS is sent only when all ten items are answered 1-5, and a new questionnaire starts blank', () => {
  const model = new StudyModel();
  model.apply(study({ phase: 'questions', questionnaire: 'tlx' }), 0);
  model.setTlx(0, 0);
  model.apply(study({ phase: 'questions', questionnaire: 'sus', task: null }), 1);
  assert.deepEqual(model.tlx, [50, 50, 50, 50, 50, 50]);
  assert.equal(SUS_ITEMS.length, 10);
  for (let i = 0; i < 8; i++) model.setSus(i, (i % 5) + 1);
  model.setSus(8, 6); // out of range: not an answer
  model.setSus(9, 2.5);
  assert.deepEqual(model.answer(), { missing: 'please answer items 9, 10' });
  model.setSus(8, 4);
  model.setSus(9, 2);
  assert.deepEqual(model.answer(), {
    command: { identifier: 'study/answer', questionnaire: 'sus', answers: [1, 2, 3, 4, 5, 1, 2, 3, 4, 2] },
  });
  // The same questionnaire's message again (another client joined, say) keeps the answers being given.
  model.apply(study({ phase: 'questions', questionnaire: 'sus', task: null }), 2);
  assert.equal(model.sus[9], 2);
});

test('nothing is sent for a questionnaire or a probe that is not asked', () => {
  const model = new StudyModel();
  assert.deepEqual(model.answer(), { missing: 'no questionnaire is asked now' });
  assert.equal(model.join(), null); // no study yet, no participant
  model.apply(study({ phase: 'task' }), 0);
  assert.equal(model.answerProbe('corridor'), null);
  const probe = { question: 'room', robot: 'robot2', choices: ['corridor', 'plumbing'] };
  model.apply(study({ phase: 'probe', probe }), 1);
  assert.equal(probeQuestion(probe), 'Which room is robot2 in?');
  assert.equal(model.answerProbe('kitchen'), null);
  assert.deepEqual(model.answerProbe('plumbing'), { identifier: 'study/answer', probe: 'plumbing' });
});

test('in VR the SUS is asked an item at a time on the menu: an answer moves on, Send once all ten are answered', () => {
  const model = new StudyModel();
  model.apply(study({ phase: 'questions', questionnaire: 'sus' }), 0);
  let q = /** @type {import('../src/study_model.js').MenuQuestion} */ (model.menuQuestion());
  assert.ok(q.lines.join(' ').startsWith('SUS 1/10: I think that I would like'), q.lines.join(' '));
  assert.ok(
    q.lines.every((line) => line.length <= 60),
    String(q.lines),
  );
  assert.deepEqual(
    q.answers.map((b) => b.label),
    ['1 Disagree', '2', '3', '4', '5 Agree'],
  );
  assert.equal(q.moves.find((b) => b.id === 'study:send')?.enabled, false);
  for (let i = 0; i < SUS_ITEMS.length; i++) assert.deepEqual(model.pressMenu(`study:sus:${(i % 5) + 1}`), {});
  q = /** @type {import('../src/study_model.js').MenuQuestion} */ (model.menuQuestion());
  assert.ok(q.lines.join(' ').startsWith('SUS 10/10'), 'the last item stays shown');
  assert.equal(q.answers.find((b) => b.active)?.id, 'study:sus:5');
  model.pressMenu('study:prev');
  assert.ok(model.menuQuestion()?.lines[0].startsWith('SUS 9/10'));
  assert.deepEqual(model.pressMenu('study:send'), {
    command: { identifier: 'study/answer', questionnaire: 'sus', answers: [1, 2, 3, 4, 5, 1, 2, 3, 4, 5] },
  });
});

test('in VR the TLX scales are set by their quarters and steps of 5, and an unanswered SUS item is named', () => {
  const model = new StudyModel();
  model.apply(study({ phase: 'questions', questionnaire: 'sus' }), 0);
  model.pressMenu('study:sus:4');
  assert.deepEqual(model.pressMenu('study:send'), { missing: 'please answer items 2, 3, 4, 5, 6, 7, 8, 9, 10' });
  model.apply(study({ phase: 'questions', questionnaire: 'tlx' }), 1);
  assert.equal(model.item, 0, 'a new questionnaire starts at its first item');
  model.pressMenu('study:tlx:75');
  model.pressMenu('study:tlx:+5');
  model.pressMenu('study:next');
  model.pressMenu('study:tlx:0');
  model.pressMenu('study:tlx:-5'); // at its end: stays 0
  const q = /** @type {import('../src/study_model.js').MenuQuestion} */ (model.menuQuestion());
  assert.ok(q.lines.join(' ').includes('TLX 2/6') && q.lines.join(' ').includes('Now 0'), q.lines.join(' '));
  assert.equal(q.answers.find((b) => b.id === 'study:tlx:-5')?.enabled, false);
  assert.deepEqual(model.pressMenu('study:send'), {
    command: { identifier: 'study/answer', questionnaire: 'tlx', answers: [80, 0, 50, 50, 50, 50] },
  });
});

test("in VR a probe's question and its choices are the menu's, and nothing is asked during a task", () => {
  const model = new StudyModel();
  model.apply(study({ phase: 'task' }), 0);
  assert.equal(model.menuQuestion(), null);
  const probe = { question: 'room', robot: 'robot2', choices: ['Plumbing', 'Power distribution'] };
  model.apply(study({ phase: 'probe', probe }), 1);
  const q = /** @type {import('../src/study_model.js').MenuQuestion} */ (model.menuQuestion());
  assert.deepEqual(q.lines, ['Which room is robot2 in?']);
  assert.deepEqual(
    q.answers.map((b) => b.id),
    ['study:probe:Plumbing', 'study:probe:Power distribution'],
  );
  assert.deepEqual(model.pressMenu('study:probe:Plumbing'), {
    command: { identifier: 'study/answer', probe: 'Plumbing' },
  });
  assert.deepEqual(model.pressMenu('study:probe:Kitchen'), { missing: 'that is not one of the answers' });
});
