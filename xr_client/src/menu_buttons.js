// @ts-check
/**
 * What the menu shows, from its state: every button with its label, group, and whether it is active and enabled
 * (the VR panel and the desktop overlay both draw this list). Building it changes nothing; what a press does is
 * menu_state.js's.
 */

import { may } from './roles.js';
import { pageLabel } from './robot_pages.js';

/** @typedef {import('./menu_state.js').MenuState} MenuState */
/** @typedef {import('./menu_state.js').MenuButton} MenuButton */

/**
 * Whether the selected robot can be commanded, and why not (a label's suffix).
 * @typedef {{selected: import('./menu_state.js').MenuRobot | null, pov: boolean, latched: boolean, command: boolean,
 *   why: string, held: boolean}} ButtonContext
 */

/** @param {MenuState} menu @returns {MenuButton[]} */
export function menuButtons(menu) {
  const selected = menu.robot(menu.selected);
  const latched = selected !== null && menu.latched.includes(selected.name);
  /** @type {ButtonContext} */
  const context = {
    selected,
    pov: menu.mode === 'pov',
    latched,
    command: menu.canCommand && selected !== null && !latched,
    why: !menu.operator ? ` (${menu.role})` : !menu.connected ? ' (offline)' : latched ? ' (E-STOPPED)' : '',
    held: menu.holder !== null && !latched,
  };
  return [
    ...questionButtons(menu),
    ...modeButtons(menu, context),
    ...robotButtons(menu),
    ...toolButtons(menu, context),
    ...cameraButtons(menu, context),
    ...missionButtons(menu),
    ...alertButtons(menu),
    ...findingButtons(menu),
    ...optionButtons(menu),
    ...estopButtons(menu, context),
  ];
}

/** The groups of a study's question (questionButtons): the VR panel's first rows while one is asked. */
export const QUESTION_GROUPS = Object.freeze(['question', 'question2', 'answers', 'answering']);

/**
 * A study's question asked now: its words (a caption a line), its answers, and Back, Next and Send.
 * @param {MenuState} menu @returns {MenuButton[]}
 */
function questionButtons(menu) {
  const q = menu.question;
  if (!q) return [];
  return [
    ...q.lines.map((label, i) => ({ id: `study:line${i}`, label, group: i ? 'question2' : 'question', active: false,
                                     enabled: false, caption: true })), // prettier-ignore
    ...q.answers.map((b) => ({ ...b, group: 'answers' })),
    ...q.moves.map((b) => ({ ...b, group: 'answering' })),
  ];
}

/**
 * What the VR panel shows of the buttons: while a study's question is asked, only it and E-STOP (the headset's
 * only way to answer; the robots wait, and E-STOP never goes). @param {MenuButton[]} buttons @returns {MenuButton[]}
 */
export function panelButtons(buttons) {
  if (!buttons.some((b) => QUESTION_GROUPS.includes(b.group))) return buttons;
  return buttons.filter((b) => QUESTION_GROUPS.includes(b.group) || b.group === 'estop');
}

/**
 * A button a robot, on the page the row shows, and in a fleet larger than a page, `‹`, which robots the page holds,
 * and `›` in a row of their own (`pages`) under them. @param {MenuState} menu @returns {MenuButton[]}
 */
function robotButtons(menu) {
  const page = menu.robotPages.shown(menu.robots.length);
  const robots = menu.robots.slice(page.first, page.last).map((robot) => ({
    id: `robot:${robot.name}`,
    label: robot.name,
    group: 'robots',
    active: robot.name === menu.selected,
    enabled: true,
  }));
  if (!page.paged) return robots;
  return [
    ...robots,
    { id: 'robots:prev', label: '‹', group: 'pages', active: false, enabled: true },
    { id: 'robots:page', label: pageLabel(page), group: 'pages', active: false, enabled: false, caption: true },
    { id: 'robots:next', label: '›', group: 'pages', active: false, enabled: true },
  ];
}

/**
 * Free Roam, Robot POV for a selected robot with a camera, and what the world is drawn from: the live 3D map, the
 * twin. (In the View row: in the Options row, eight buttons made Close too narrow to pinch by a glance.)
 * @param {MenuState} menu @param {ButtonContext} c
 */
function modeButtons(menu, { selected, pov }) {
  const options = menu.options;
  return [
    { id: 'mode:free_roam', label: 'Free Roam', group: 'mode', active: !pov, enabled: true },
    {
      id: 'mode:pov',
      label:
        selected === null ? 'Robot POV (select a robot)' : selected.hasCamera ? 'Robot POV' : 'Robot POV (no camera)',
      group: 'mode',
      active: pov,
      enabled: pov || (selected?.hasCamera ?? false),
    },
    { id: 'opt:map3d', label: '3D map', group: 'mode', active: options.map3d, enabled: true },
    { id: 'opt:twin', label: 'Twin', group: 'mode', active: options.twin, enabled: true },
  ];
}

/**
 * The exclusive tools, Cancel goal, and Take over while another operator holds the robot.
 * @param {MenuState} menu @param {ButtonContext} c @returns {MenuButton[]}
 */
function toolButtons(menu, { selected, pov, command, why, held }) {
  return [
    {
      id: 'tool:teleop',
      label: held ? `Teleop (held by ${menu.holder})` : `Teleop${why}`,
      group: 'tools',
      active: menu.tool === 'teleop',
      enabled: command && !held,
    },
    {
      id: 'tool:goal',
      label: pov ? 'Goal (free roam only)' : `Goal${why}`,
      group: 'tools',
      active: menu.tool === 'goal',
      enabled: command && !pov,
    },
    // In Robot POV, Inspect marks a target on the live image: a gaze dwell in VR, a click on the desktop.
    {
      id: 'tool:inspect',
      label: pov ? 'Inspect (on the image)' : 'Inspect',
      group: 'tools',
      active: menu.tool === 'inspect',
      enabled: true,
    },
    {
      id: 'goal:cancel',
      label: 'Cancel goal',
      group: 'tools',
      active: false,
      enabled: command && menu.goalActive && !held,
    },
    ...(held && selected
      ? [
          {
            id: 'lease:take',
            label: `Take over from ${menu.holder}`,
            group: 'tools',
            active: false,
            enabled: command,
          },
        ]
      : []),
  ];
}

/** Snapshot and Live, in Robot POV. @param {MenuState} menu @param {ButtonContext} c @returns {MenuButton[]} */
function cameraButtons(menu, { pov }) {
  return [
    {
      id: 'camera:snapshot',
      label: pov ? 'Snapshot' : 'Snapshot (POV only)',
      group: 'camera',
      active: false,
      enabled: pov && menu.connected,
    },
    {
      id: 'camera:live',
      label: menu.live ? 'Live: on' : 'Live',
      group: 'camera',
      active: menu.live,
      enabled: pov && menu.connected,
    },
  ];
}

/**
 * Inspection missions: the demo, all targets, the picked ones; Pause/Resume and Abort while one runs.
 * @param {MenuState} menu @returns {MenuButton[]}
 */
function missionButtons(menu) {
  return [
    {
      id: 'mission:demo',
      label: 'Run demo mission',
      group: 'mission',
      active: false,
      enabled: may(menu.role, 'inspect') && menu.connected,
    },
    {
      id: 'mission:all',
      label: menu.selected ? `All targets: ${menu.selected}` : 'All targets: fleet',
      group: 'mission',
      active: false,
      enabled: may(menu.role, 'inspect') && menu.connected,
    },
    ...(menu.picked
      ? [
          {
            id: 'mission:picked',
            label: `Inspect picked (${menu.picked}): ${menu.selected ?? 'fleet'}`,
            group: 'mission',
            active: false,
            enabled: may(menu.role, 'inspect') && menu.connected,
          },
        ]
      : []),
    ...(menu.mission
      ? [
          {
            id: 'mission:toggle',
            label: menu.mission === 'paused' ? 'Resume mission' : 'Pause mission',
            group: 'mission',
            active: menu.mission === 'paused',
            enabled: may(menu.role, 'inspect') && menu.connected,
          },
          {
            id: 'mission:abort',
            label: 'Abort mission',
            group: 'mission',
            active: false,
            enabled: may(menu.role, 'inspect') && menu.connected,
          },
        ]
      : []),
  ];
}

/** Alerts shown as buttons at most: the VR panel's row stays readable (60 characters a button at its width). */
export const MENU_ALERTS = 2;
const ALERT_TEXT = 60;

/**
 * The newest open alerts, each acknowledged by its button (operators), and how many more wait on the desktop's list.
 * @param {MenuState} menu @returns {MenuButton[]}
 */
function alertButtons(menu) {
  const shown = menu.alerts.slice(0, MENU_ALERTS);
  const more = menu.alerts.length - shown.length;
  const clip = (/** @type {string} */ text) => (text.length > ALERT_TEXT ? `${text.slice(0, ALERT_TEXT - 1)}…` : text);
  return [
    ...shown.map((a) => ({
      id: `alert:${a.alert}`,
      label: `Acknowledge: ${clip(a.text)}`,
      group: 'alerts',
      active: false,
      enabled: may(menu.role, 'inspect') && menu.connected,
      danger: a.severity === 'critical',
    })),
    ...(more > 0
      ? [
          {
            id: 'alerts:more',
            label: `${more} more alert${more > 1 ? 's' : ''}`,
            group: 'alerts',
            active: false,
            enabled: false,
          },
        ]
      : []),
  ];
}

/**
 * The pins in the twin: all findings, or only what changed since each target's last round; a pair, as the view's
 * modes are (viewers too: it changes only what this client shows). @param {MenuState} menu @returns {MenuButton[]}
 */
function findingButtons(menu) {
  if (menu.changed === 0 && !menu.sinceLastRound) return []; // nothing changed: no row to read past
  return [
    { id: 'findings:all', label: 'All findings', group: 'findings', active: !menu.sinceLastRound, enabled: true },
    {
      id: 'findings:since',
      label: 'Changed since last round',
      group: 'findings',
      active: menu.sinceLastRound,
      enabled: true,
    },
  ];
}

/** The options (menu_options.js), the sound's, and Close. @param {MenuState} menu @returns {MenuButton[]} */
function optionButtons(menu) {
  const options = menu.options;
  return [
    { id: 'opt:seated', label: 'Seated', group: 'options', active: options.seated, enabled: true },
    { id: 'opt:smooth', label: 'Smooth move', group: 'options', active: options.smooth, enabled: true },
    { id: 'opt:overview', label: 'Overview', group: 'options', active: options.overview, enabled: true },
    { id: 'opt:scans', label: 'Scans', group: 'options', active: options.scans, enabled: true },
    { id: 'opt:dwell', label: 'Gaze press', group: 'options', active: options.dwellPress, enabled: true },
    { id: 'opt:hand', label: 'Hand 1:1', group: 'options', active: options.handOneToOne, enabled: true },
    { id: 'opt:mute', label: 'Mute', group: 'sound', active: options.muted, enabled: true },
    {
      id: 'opt:volume-',
      label: `Volume − (${Math.round(options.volume * 100)} %)`,
      group: 'sound',
      active: false,
      enabled: options.volume > 0,
    },
    { id: 'opt:volume+', label: 'Volume +', group: 'sound', active: false, enabled: options.volume < 1 },
    { id: 'opt:ticks', label: 'Hazard ticks', group: 'sound', active: options.ticks, enabled: true },
    { id: 'menu:close', label: 'Close', group: 'options', active: false, enabled: true },
  ];
}

/**
 * E-STOP (every robot), Stop for the selected one, and Reset E-STOP while one is latched.
 * @param {MenuState} menu @param {ButtonContext} c @returns {MenuButton[]}
 */
function estopButtons(menu, { selected, latched }) {
  const stop = may(menu.role, 'stop'); // an inspector stops robots too: stopping is always safe
  /** @type {MenuButton[]} */
  const list = [{ id: 'estop', label: 'E-STOP', group: 'estop', active: menu.estopped, enabled: stop, danger: true }];
  if (selected) {
    list.push({
      id: 'estop:robot',
      label: latched ? `${selected.name} stopped` : `Stop ${selected.name}`,
      group: 'estop',
      active: latched,
      enabled: stop && !latched,
      danger: true,
    });
  }
  if (menu.estopped) {
    list.push({
      id: 'estop:reset',
      label: 'Reset E-STOP',
      group: 'estop',
      active: false,
      enabled: may(menu.role, 'reset') && menu.connected,
    });
  }
  return list;
}
