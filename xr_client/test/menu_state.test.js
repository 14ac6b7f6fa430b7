// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ButtonEdge, MenuState } from '../src/menu_state.js';
import { MAX_STREAM_FPS } from '../src/protocol.js';
import { panelButtons } from '../src/menu_buttons.js';

function menu() {
  const m = new MenuState();
  m.setFleet(
    [
      { name: 'robot1', hasCamera: true },
      { name: 'robot2', hasCamera: true },
      { name: 'robot3', hasCamera: false },
    ],
    'operator',
  );
  return m;
}
/** @param {MenuState} m @param {string} id */
const button = (m, id) => m.buttons().find((b) => b.id === id);

test('one press of the controller button is one toggle, never repeated while held', () => {
  const edge = new ButtonEdge();
  const presses = [false, true, true, true, false, true, false].map((p) => edge.update(p));
  assert.deepEqual(presses, [false, true, false, false, false, true, false]);
  const m = menu();
  assert.deepEqual(m.toggle(), [{ type: 'menu', open: true }]);
  assert.equal(m.open, true);
  assert.deepEqual(m.toggle(), [{ type: 'menu', open: false }]);
});

test('robots are a radio group that can be switched off', () => {
  const m = menu();
  assert.deepEqual(m.press('robot:robot2'), [{ type: 'select', robot: 'robot2' }]);
  assert.equal(m.selected, 'robot2');
  m.press('robot:robot1');
  assert.equal(m.selected, 'robot1');
  assert.equal(m.buttons().filter((b) => b.group === 'robots' && b.active).length, 1);
  m.press('robot:robot1');
  assert.equal(m.selected, null);
});

test('Teleop and Goal are exclusive, need a robot, and labels and disabled states follow the mode', () => {
  const m = menu();
  assert.equal(button(m, 'tool:teleop')?.enabled, false);
  assert.deepEqual(m.press('tool:teleop'), []);
  m.press('robot:robot2');
  m.press('tool:teleop');
  assert.equal(m.tool, 'teleop');
  // Switching to Goal stops driving first.
  assert.deepEqual(m.press('tool:goal'), [
    { type: 'stop_teleop', robot: 'robot2' },
    { type: 'tool', tool: 'goal' },
  ]);
  assert.equal(m.tool, 'goal');
  assert.equal(button(m, 'camera:snapshot')?.enabled, false);
  // Robot POV: goal off (no floor there), camera buttons on, a snapshot at once.
  const effects = m.press('mode:pov');
  assert.deepEqual(effects, [
    { type: 'tool', tool: 'none' },
    { type: 'mode', mode: 'pov' },
    { type: 'snapshot', robot: 'robot2' },
  ]);
  assert.equal(button(m, 'tool:goal')?.enabled, false);
  assert.equal(button(m, 'tool:goal')?.label, 'Goal (free roam only)');
  assert.equal(button(m, 'camera:snapshot')?.enabled, true);
  assert.equal(button(m, 'estop')?.enabled, true);
  assert.equal(button(m, 'estop')?.danger, true);
});

test('POV needs a camera; switching robot or mode stops driving and the live stream', () => {
  const m = menu();
  m.press('robot:robot3');
  assert.equal(button(m, 'mode:pov')?.enabled, false);
  assert.equal(button(m, 'mode:pov')?.label, 'Robot POV (no camera)');
  m.press('robot:robot1');
  m.press('mode:pov');
  m.press('tool:teleop');
  assert.deepEqual(m.press('camera:live'), [{ type: 'stream', robot: 'robot1', fps: MAX_STREAM_FPS }]);
  assert.equal(button(m, 'camera:live')?.active, true);
  // Another robot in POV: stop driving robot1, stop its stream, show a snapshot of robot2.
  assert.deepEqual(m.press('robot:robot2'), [
    { type: 'stop_teleop', robot: 'robot1' },
    { type: 'stream', robot: 'robot1', fps: 0 },
    { type: 'select', robot: 'robot2' },
    { type: 'snapshot', robot: 'robot2' },
  ]);
  assert.equal(m.live, false);
  // A robot without a camera in POV: back to free roam.
  const effects = m.press('robot:robot3');
  assert.deepEqual(effects.at(-1), { type: 'mode', mode: 'free_roam' });
  assert.equal(m.mode, 'free_roam');
});

test('opening the menu while driving asks for a stop; E-STOP turns teleop off', () => {
  const m = menu();
  m.press('robot:robot1');
  m.press('tool:teleop');
  assert.deepEqual(m.toggle(), [
    { type: 'stop_teleop', robot: 'robot1' },
    { type: 'menu', open: true },
  ]);
  assert.deepEqual(m.press('estop'), [
    { type: 'stop_teleop', robot: 'robot1' },
    { type: 'tool', tool: 'none' },
    { type: 'estop' },
  ]);
  assert.equal(m.tool, 'none');
});

test('Reset E-STOP is offered beside E-STOP while a stop is latched, to operators only', () => {
  const m = menu();
  m.setConnected(true);
  assert.equal(button(m, 'estop:reset'), undefined);
  m.press('robot:robot1');
  m.press('tool:teleop');
  m.setLatched(['robot1']);
  assert.equal(m.tool, 'none', 'the latched robot cannot be driven');
  assert.equal(button(m, 'tool:teleop')?.enabled, false);
  assert.equal(button(m, 'tool:teleop')?.label, 'Teleop (E-STOPPED)');
  m.press('robot:robot2');
  assert.equal(button(m, 'tool:teleop')?.enabled, true, 'another robot still can');
  assert.equal(button(m, 'estop')?.active, true);
  assert.equal(button(m, 'estop:reset')?.enabled, true);
  assert.deepEqual(m.press('estop:reset'), [{ type: 'estop_reset' }]);
  const viewer = new MenuState();
  viewer.setFleet([{ name: 'robot1', hasCamera: true }], 'viewer');
  viewer.setConnected(true);
  viewer.setLatched(['robot1']);
  assert.equal(button(viewer, 'estop:reset')?.enabled, false);
  assert.deepEqual(viewer.press('estop:reset'), []);
  m.setLatched([]);
  assert.equal(button(m, 'estop:reset'), undefined);
});

test('a reconnect keeps the selection, asks for the live stream again, and drops vanished robots', () => {
  const m = menu();
  m.press('robot:robot2');
  m.press('mode:pov');
  m.press('camera:live');
  m.setConnected(false);
  assert.equal(button(m, 'camera:live')?.enabled, false);
  assert.deepEqual(
    m.setFleet(
      [
        { name: 'robot1', hasCamera: true },
        { name: 'robot2', hasCamera: true },
      ],
      'operator',
    ),
    [{ type: 'stream', robot: 'robot2', fps: MAX_STREAM_FPS }],
  );
  const effects = m.setFleet([{ name: 'robot1', hasCamera: true }], 'operator');
  assert.equal(m.selected, null);
  assert.equal(m.mode, 'free_roam');
  assert.ok(effects.some((e) => e.type === 'stream' && e.fps === 0));
});

test('Cancel goal is enabled while the selected robot follows a goal', () => {
  const m = menu();
  m.press('robot:robot1');
  assert.equal(button(m, 'goal:cancel')?.enabled, false);
  m.show('goalActive', true);
  assert.deepEqual(m.press('goal:cancel'), [{ type: 'cancel', robot: 'robot1' }]);
  m.press('robot:robot2'); // another robot: its own status decides
  assert.equal(button(m, 'goal:cancel')?.enabled, false);
});

test('a viewer cannot command: tools and E-STOP are disabled, and the version moves on every change', () => {
  const m = new MenuState();
  m.setFleet([{ name: 'robot1', hasCamera: false }], 'viewer');
  m.press('robot:robot1');
  assert.equal(button(m, 'tool:teleop')?.enabled, false);
  assert.equal(button(m, 'tool:teleop')?.label, 'Teleop (viewer)');
  assert.equal(button(m, 'estop')?.enabled, false);
  const v = m.version;
  m.press('opt:seated');
  assert.equal(m.options.seated, true);
  assert.ok(m.version > v);
});

test('the mission buttons: the demo, every target for the selected robot or the fleet, and its mission controls', () => {
  const menu = new MenuState();
  menu.setFleet([{ name: 'robot1', hasCamera: true }], 'operator');
  menu.setConnected(true);
  assert.deepEqual(menu.press('mission:demo'), [{ type: 'mission', action: 'start', robot: null }]);
  assert.equal(menu.buttons().find((b) => b.id === 'mission:all')?.label, 'All targets: fleet');
  menu.select('robot1');
  assert.deepEqual(menu.press('mission:all'), [{ type: 'mission', action: 'all', robot: 'robot1' }]);
  assert.equal(
    menu.buttons().find((b) => b.id === 'mission:toggle'),
    undefined,
  ); // no mission: no controls
  menu.show('mission', 'running');
  assert.deepEqual(menu.press('mission:toggle'), [{ type: 'mission', action: 'pause', robot: 'robot1' }]);
  menu.show('mission', 'paused');
  assert.equal(menu.buttons().find((b) => b.id === 'mission:toggle')?.label, 'Resume mission');
  assert.deepEqual(menu.press('mission:abort'), [{ type: 'mission', action: 'abort', robot: 'robot1' }]);
  menu.setConnected(false);
  assert.deepEqual(menu.press('mission:demo'), []); // disabled while disconnected
});

test('the volume steps in fifths from wherever the slider left it, and its buttons stop at the ends', () => {
  const m = menu();
  assert.equal(button(m, 'opt:volume-')?.label, 'Volume − (60 %)');
  m.press('opt:volume+');
  m.press('opt:volume+');
  assert.equal(m.options.volume, 1);
  assert.equal(button(m, 'opt:volume+')?.enabled, false, 'full: + is off');
  m.press('opt:volume+');
  assert.equal(m.options.volume, 1);
  m.options.volume = 0.63; // the header's slider
  m.press('opt:volume-');
  assert.equal(m.options.volume, 0.4);
  m.press('opt:volume-');
  m.press('opt:volume-');
  assert.equal(m.options.volume, 0);
  assert.equal(button(m, 'opt:volume-')?.enabled, false, 'silent: − is off');
  assert.equal(button(m, 'opt:volume-')?.label, 'Volume − (0 %)');
  assert.equal(button(m, 'opt:ticks')?.active, false);
  m.press('opt:ticks');
  assert.equal(m.options.ticks, true, 'the hazard ticks switch on from the menu, in VR too');
  assert.equal(button(m, 'opt:ticks')?.group, 'sound');
});

test('open alerts are a row of the menu, the newest two each acknowledged by its button, and a count of the rest', () => {
  const m = menu();
  assert.equal(m.buttons().filter((b) => b.group === 'alerts').length, 0, 'no alerts, no row');
  const text = 'Anomaly at Spill (robot2): gas 312.0 ppm over its 50 ppm limit, seen by the camera at the door';
  const alerts = [
    { alert: 'al-3', text, severity: 'critical', robot: 'robot2' },
    { alert: 'al-2', text: 'Schedule nightly missed 1 run', severity: 'warning', robot: null },
    { alert: 'al-1', text: 'robot3 went offline during its mission', severity: 'warning', robot: 'robot3' },
  ];
  m.show('alerts', alerts);
  const row = m.buttons().filter((b) => b.group === 'alerts');
  assert.deepEqual(
    row.map((b) => [b.id, b.enabled, Boolean(b.danger)]),
    [
      ['alert:al-3', true, true],
      ['alert:al-2', true, false],
      ['alerts:more', false, false],
    ],
  );
  assert.ok(row[0].label.startsWith('Acknowledge: Anomaly at Spill') && row[0].label.length <= 74, row[0].label);
  assert.equal(row[2].label, '1 more alert');
  assert.deepEqual(m.press('alert:al-3'), [{ type: 'alert_ack', alert: 'al-3' }]);
  assert.deepEqual(m.press('alerts:more'), [], 'the count is not a button that does anything');
  // Acknowledged (here or on another page): the model's list shrinks, the row follows.
  m.show('alerts', alerts.slice(1));
  assert.deepEqual(
    m
      .buttons()
      .filter((b) => b.group === 'alerts')
      .map((b) => b.id),
    ['alert:al-2', 'alert:al-1'],
  );
  // A viewer sees them and cannot acknowledge.
  m.setFleet(m.robots, 'viewer');
  assert.ok(
    m
      .buttons()
      .filter((b) => b.group === 'alerts')
      .every((b) => !b.enabled),
  );
});

test('the findings row switches the pins between all findings and what changed since the last round', () => {
  const m = new MenuState();
  const row = () =>
    m
      .buttons()
      .filter((b) => b.group === 'findings')
      .map((b) => [b.id, b.active, b.enabled]);
  assert.deepEqual(row(), [], 'nothing changed since the last round: no row to read past');
  m.show('changed', 2);
  assert.deepEqual(row(), [
    ['findings:all', true, true],
    ['findings:since', false, true],
  ]);
  assert.deepEqual(m.press('findings:since'), [{ type: 'since_last_round', on: true }]);
  assert.deepEqual(row(), [
    ['findings:all', false, true],
    ['findings:since', true, true],
  ]);
  assert.deepEqual(m.press('findings:since'), [{ type: 'since_last_round', on: false }], 'pressed again: all');
  m.press('findings:since');
  assert.deepEqual(m.press('findings:all'), [{ type: 'since_last_round', on: false }]);
  m.show('sinceLastRound', true); // the desktop panel's switch turned it on
  assert.equal(m.buttons().find((b) => b.id === 'findings:since')?.active, true);
});

/** A fleet of `n` robots, robot1..robotN. @param {number} n */
function fleetOf(n) {
  const m = new MenuState();
  m.setFleet(
    Array.from({ length: n }, (_, i) => ({ name: `robot${i + 1}`, hasCamera: false })),
    'operator',
  );
  return m;
}
/** @param {MenuState} m */
const robotRow = (m) =>
  m
    .buttons()
    .filter((b) => b.group === 'robots')
    .map((b) => b.label);
/** @param {MenuState} m */
const pageRow = (m) =>
  m
    .buttons()
    .filter((b) => b.group === 'pages')
    .map((b) => b.label);

test('a fleet of six robots is one row of buttons, without pages', () => {
  const m = fleetOf(6);
  assert.deepEqual(robotRow(m), ['robot1', 'robot2', 'robot3', 'robot4', 'robot5', 'robot6']);
  assert.deepEqual(pageRow(m), []);
});

test('twenty robots are paged six at a time by their full names, the pages turning round the ends', () => {
  const m = fleetOf(20);
  assert.deepEqual(robotRow(m), ['robot1', 'robot2', 'robot3', 'robot4', 'robot5', 'robot6']);
  assert.deepEqual(pageRow(m), ['‹', 'robots 1-6 of 20', '›']);
  assert.equal(button(m, 'robots:page')?.enabled, false, 'the label is no button');
  assert.deepEqual(m.press('robots:next'), []);
  m.press('robots:next');
  assert.deepEqual(robotRow(m), ['robot13', 'robot14', 'robot15', 'robot16', 'robot17', 'robot18']);
  assert.deepEqual(pageRow(m), ['‹', 'robots 13-18 of 20', '›']);
  // A robot of the page shown is pressed as in a small fleet.
  assert.deepEqual(m.press('robot:robot17'), [{ type: 'select', robot: 'robot17' }]);
  m.press('robots:next');
  assert.deepEqual(robotRow(m), ['robot19', 'robot20']);
  assert.deepEqual(pageRow(m), ['‹', 'robots 19-20 of 20', '›']);
  m.press('robots:next');
  assert.deepEqual(pageRow(m), ['‹', 'robots 1-6 of 20', '›']);
  m.press('robots:prev');
  assert.deepEqual(pageRow(m), ['‹', 'robots 19-20 of 20', '›']);
  // A robot on another page is not in the row: its button cannot be pressed.
  assert.deepEqual(m.press('robot:robot3'), []);
  assert.equal(m.selected, 'robot17');
});

test("the menu opens on the selected robot's page, and a selection made elsewhere turns to its page", () => {
  const m = fleetOf(20);
  m.select('robot17');
  assert.equal(robotRow(m)[4], 'robot17');
  m.press('robots:prev');
  m.press('robots:prev');
  assert.deepEqual(pageRow(m), ['‹', 'robots 1-6 of 20', '›']);
  m.setOpen(true);
  m.setOpen(false);
  m.setOpen(true);
  assert.deepEqual(pageRow(m), ['‹', 'robots 13-18 of 20', '›']);
  assert.equal(button(m, 'robot:robot17')?.active, true);
  m.select('robot8'); // a robot clicked in the twin, or named by voice
  assert.deepEqual(pageRow(m), ['‹', 'robots 7-12 of 20', '›']);
});

test('a fleet that shrinks under the page shown shows its last page', () => {
  const m = fleetOf(20);
  m.select('robot20');
  const fewer = Array.from({ length: 8 }, (_, i) => ({ name: `robot${i + 1}`, hasCamera: false }));
  m.setFleet(fewer, 'operator');
  assert.deepEqual(robotRow(m), ['robot7', 'robot8']);
  assert.deepEqual(pageRow(m), ['‹', 'robots 7-8 of 8', '›']);
  m.setFleet(fewer.slice(0, 6), 'operator');
  assert.equal(robotRow(m).length, 6);
  assert.deepEqual(pageRow(m), []);
});

test('an inspector is offered what the relay accepts from one: E-STOP, missions and alerts, never driving or reset', () => {
  const m = new MenuState();
  m.setFleet([{ name: 'robot1', hasCamera: true }], 'inspector');
  m.setConnected(true);
  m.press('robot:robot1');
  m.show('alerts', [{ alert: 'a1', text: 'Past its limit', severity: 'warning' }]);
  for (const id of ['tool:teleop', 'tool:goal']) {
    assert.equal(button(m, id)?.enabled, false, id);
    assert.match(button(m, id)?.label ?? '', /\(inspector\)$/);
  }
  for (const id of ['estop', 'estop:robot', 'mission:demo', 'mission:all', 'alert:a1'])
    assert.equal(button(m, id)?.enabled, true, id);
  m.setLatched(['robot1']);
  assert.equal(button(m, 'estop:reset')?.enabled, false, 'an inspector never resets an E-STOP');
  // An admin has an operator's buttons.
  const admin = new MenuState();
  admin.setFleet([{ name: 'robot1', hasCamera: true }], 'admin');
  admin.setConnected(true);
  admin.press('robot:robot1');
  assert.equal(button(admin, 'tool:teleop')?.enabled, true);
});

test("a study's question heads the menu, and the VR panel then shows only it and E-STOP; its presses are answers", () => {
  const menu = new MenuState();
  menu.setFleet([{ name: 'robot1', hasCamera: true }], 'operator');
  const version = menu.version;
  menu.show('question', {
    lines: ['SUS 1/10: I think that I would like to use this system', 'frequently.'],
    answers: [{ id: 'study:sus:1', label: '1 Disagree', active: false, enabled: true }],
    moves: [{ id: 'study:send', label: 'Send answers', active: false, enabled: false }],
  });
  assert.ok(menu.version > version, 'the menu is drawn again');
  const drawn = menu.version;
  menu.show('question', {
    lines: ['SUS 1/10: I think that I would like to use this system', 'frequently.'],
    answers: [{ id: 'study:sus:1', label: '1 Disagree', active: false, enabled: true }],
    moves: [{ id: 'study:send', label: 'Send answers', active: false, enabled: false }],
  });
  assert.equal(menu.version, drawn, 'the same question from the next study message: not drawn again');
  const buttons = menu.buttons();
  assert.deepEqual(
    buttons.slice(0, 4).map((b) => [b.group, b.caption ?? false]),
    [
      ['question', true],
      ['question2', true],
      ['answers', false],
      ['answering', false],
    ],
  );
  assert.ok(
    buttons.some((b) => b.id === 'robot:robot1'),
    'the desktop menu keeps its other buttons',
  );
  const panel = panelButtons(buttons);
  assert.deepEqual([...new Set(panel.map((b) => b.group))], ['question', 'question2', 'answers', 'answering', 'estop']);
  assert.deepEqual(menu.press('study:sus:1'), [{ type: 'study_press', id: 'study:sus:1' }]);
  assert.deepEqual(menu.press('study:send'), [], 'a disabled Send does nothing');
  menu.show('question', null);
  assert.equal(panelButtons(menu.buttons()).length, menu.buttons().length);
});
