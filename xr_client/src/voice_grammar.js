// @ts-check
/**
 * Voice commands: what a recognised phrase means, and which ones wait for a confirmation. Pure: no DOM, no
 * speech API, time passed in (the page's wiring is view/voice_control.js; node tests in test/voice_grammar.test.js).
 *
 * The grammar is small on purpose (a factory study reached 97 % with seven commands): select a robot, send it to a
 * room or a named inspection target, stop one robot, stop all (also "emergency stop"), snapshot, start / pause /
 * resume / abort a mission, teleport to a robot, switch views, and "confirm" / "cancel". Robots are named as the
 * fleet names them ("robot1"), as spoken ("robot one", "robot 1") or by number when the fleet's names end in one.
 * Recognisers hear "robot two" as "robot to" or "robot too": after "robot", those count as the number.
 *
 * Safety: stops act at once and are never held for confirmation; anything that makes a robot move (a goal, a
 * mission start or resume) is shown and waits for "confirm" (or "yes", "go") for CONFIRM_MS, then lapses
 * (`VoiceConfirm.confirm` is there for a pinch or a trigger to confirm too, once hands are wired). What was heard
 * is always returned, with the command or the reason it was refused.
 */
import { nameNumber } from './wording.js';

/** How long a motion command waits for its confirmation (ms). */
export const CONFIRM_MS = 8000;

/**
 * @typedef {{kind: 'room' | 'target', name: string, title: string, x: number, y: number}} Place
 * @typedef {{kind: 'select', robot: string}
 *   | {kind: 'goto', robot: string, place: Place}
 *   | {kind: 'stop', robot: string}
 *   | {kind: 'stop_all'}
 *   | {kind: 'stop_group', group: string, robots: string[]}
 *   | {kind: 'snapshot', robot: string | null}
 *   | {kind: 'mission', action: 'start' | 'pause' | 'resume' | 'abort'}
 *   | {kind: 'teleport', robot: string}
 *   | {kind: 'view', view: 'pov' | 'free_roam'}
 *   | {kind: 'confirm'}
 *   | {kind: 'cancel'}} VoiceCommand
 * @typedef {{heard: string, command: VoiceCommand} | {heard: string, refused: string}} Parsed
 * @typedef {{robots: string[], rooms: {name: string, title: string, bounds: number[]}[],
 *   targets: {name: string, x: number, y: number}[], selected: string | null,
 *   groups?: {label: string, robots: string[]}[]}} Vocabulary groups: each team and room with robots (robot_groups.js)
 */

const NUMBERS = new Map(
  Object.entries({
    zero: 0,
    one: 1,
    won: 1,
    two: 2,
    three: 3,
    four: 4,
    five: 5,
    six: 6,
    seven: 7,
    eight: 8,
    nine: 9,
    ten: 10,
    eleven: 11,
    twelve: 12,
    thirteen: 13,
    fourteen: 14,
    fifteen: 15,
    sixteen: 16,
    seventeen: 17,
    eighteen: 18,
    nineteen: 19,
    twenty: 20,
    first: 1,
    second: 2,
    third: 3,
  }),
);
/** Tens said in words, for a robot's number past twenty ("robot seventy three": robot73, in a fleet of a hundred). */
const TENS = new Map(
  Object.entries({ twenty: 20, thirty: 30, forty: 40, fifty: 50, sixty: 60, seventy: 70, eighty: 80, ninety: 90 }),
);
/** What recognisers write for a number right after "robot" ("robot to go to ..."). */
const AFTER_ROBOT = new Map(Object.entries({ to: 2, too: 2, for: 4, fore: 4, ate: 8 }));
const FILLERS = new Set([
  'please',
  'uh',
  'um',
  'er',
  'okay',
  'ok',
  'hey',
  'now',
  'the',
  'a',
  'could',
  'can',
  'would',
  'you',
  'kindly',
  'station',
  'number',
  'just',
  'then',
]);
/** Words that, with a robot and nothing else, select it ("switch to robot one"). */
const SELECT = new Set(['select', 'choose', 'switch', 'pick', 'focus', 'to', 'on', 'use']);
const GO = [
  ['go', 'to'],
  ['drive', 'to'],
  ['navigate', 'to'],
  ['move', 'to'],
  ['head', 'to'],
  ['goto'],
  ['go'],
  ['send', 'to'],
  ['travel', 'to'],
];

/** Lower case, no punctuation, words and digits apart ("robot2" -> "robot 2"). @param {string} text */
export function words(text) {
  return text
    .toLowerCase()
    .replace(/[-_]/g, ' ')
    .replace(/[^a-z0-9 ]+/g, ' ')
    .replace(/([a-z])(\d)/g, '$1 $2')
    .split(/\s+/)
    .filter(Boolean);
}

/**
 * A number said in more than one word, as one: "seventy three" -> "73", "one hundred" / "a hundred" -> "100".
 * @param {string[]} w words @returns {string[]}
 */
function joinNumbers(w) {
  const out = [];
  for (let i = 0; i < w.length; i++) {
    const tens = TENS.get(w[i]);
    const unit = NUMBERS.get(w[i + 1] ?? '') ?? 0;
    const isUnit = unit >= 1 && unit <= 9 && !['won', 'first', 'second', 'third'].includes(w[i + 1]);
    if (tens !== undefined) {
      out.push(String(tens + (isUnit ? unit : 0)));
      if (isUnit) i++;
    } else if ((w[i] === 'one' || w[i] === 'a') && w[i + 1] === 'hundred') {
      out.push('100');
      i++;
    } else out.push(w[i] === 'hundred' ? '100' : w[i]);
  }
  return out;
}

/**
 * Where a room sends a robot: the middle of its bounds (the relay checks the goal against its map and says why
 * when it refuses). @param {{bounds: number[]}} room
 */
function roomPoint(room) {
  const [x0, y0, x1, y1] = room.bounds;
  return { x: Math.round(((x0 + x1) / 2) * 100) / 100, y: Math.round(((y0 + y1) / 2) * 100) / 100 };
}

/** @param {string[]} list @param {string[]} seq @returns {number} index of seq in list, or -1 */
function find(list, seq) {
  outer: for (let i = 0; i + seq.length <= list.length; i++) {
    for (let k = 0; k < seq.length; k++) if (list[i + k] !== seq[k]) continue outer;
    return i;
  }
  return -1;
}

/**
 * Take the robot the phrase names out of its words. Returns the robot (or an unknown number / name to refuse),
 * and the words left.
 * @param {string[]} w @param {string[]} robots
 * @returns {{robot: string | null, unknown: string | null, rest: string[]}}
 */
function takeRobot(w, robots) {
  // A robot's own name, spoken as words ("robot1" -> "robot 1", "scout_a" -> "scout a").
  for (const name of [...robots].sort((a, b) => b.length - a.length)) {
    const spoken = words(name);
    const at = find(w, spoken);
    if (at >= 0) return { robot: name, unknown: null, rest: [...w.slice(0, at), ...w.slice(at + spoken.length)] };
  }
  const at = w.indexOf('robot');
  if (at >= 0 && at + 1 < w.length) {
    const next = w[at + 1];
    const n = /^\d+$/.test(next) ? Number(next) : (NUMBERS.get(next) ?? AFTER_ROBOT.get(next) ?? null);
    if (n !== null) {
      const rest = [...w.slice(0, at), ...w.slice(at + 2)];
      const robot = robots.find((name) => nameNumber(name) === n) ?? null;
      return { robot, unknown: robot ? null : `robot ${n}`, rest };
    }
  }
  return { robot: null, unknown: null, rest: w };
}

/**
 * The group whose name the phrase holds (the longest, as for places): "stop north crew", "stop chemical storage".
 * @param {string[]} w @param {{label: string, robots: string[]}[]} groups
 */
function findGroup(w, groups) {
  const text = ` ${w.join(' ')} `;
  /** @type {{group: {label: string, robots: string[]}, length: number} | null} */
  let best = null;
  for (const group of groups) {
    const spoken = words(group.label).join(' ');
    if (spoken && text.includes(` ${spoken} `) && (!best || spoken.length > best.length))
      best = { group, length: spoken.length };
  }
  return best?.group ?? null;
}

/** @param {string[]} w @param {Vocabulary} vocab @returns {Place | null} */
function findPlace(w, vocab) {
  /** @type {{place: Place, length: number} | null} */
  let best = null;
  const text = ` ${w.join(' ')} `;
  for (const room of vocab.rooms) {
    for (const spoken of new Set([words(room.title).join(' '), words(room.name).join(' ')])) {
      if (spoken && text.includes(` ${spoken} `) && (!best || spoken.length > best.length)) {
        best = {
          place: { kind: 'room', name: room.name, title: room.title, ...roomPoint(room) },
          length: spoken.length,
        };
      }
    }
  }
  for (const target of vocab.targets) {
    const spoken = words(target.name).join(' ');
    if (spoken && text.includes(` ${spoken} `) && (!best || spoken.length > best.length)) {
      best = {
        place: { kind: 'target', name: target.name, title: target.name, x: target.x, y: target.y },
        length: spoken.length,
      };
    }
  }
  return best ? best.place : null;
}

/**
 * What a phrase means. @param {string} transcript what the recogniser heard @param {Vocabulary} vocab
 * @returns {Parsed}
 */
export function parse(transcript, vocab) {
  const heard = transcript.trim();
  const all = joinNumbers(words(heard)).map((t) =>
    NUMBERS.has(t) && t !== 'won' && t !== 'first' && t !== 'second' && t !== 'third' ? String(NUMBERS.get(t)) : t,
  );
  // "robot two" arrives as "robot 2"; "robot to" too (AFTER_ROBOT): restore the spoken word for takeRobot.
  const w = all.filter((t) => !FILLERS.has(t));
  const refuse = (/** @type {string} */ reason) => ({ heard, refused: reason });
  if (w.length === 0) return refuse('nothing was heard');
  const has = (/** @type {string[]} */ ...seq) => find(w, seq) >= 0;
  const { robot, unknown, rest } = takeRobot(w, vocab.robots);
  const hasRest = (/** @type {string[]} */ ...seq) => find(rest, seq) >= 0;

  // Stops first, whatever else the phrase holds: they never wait.
  const stopWord = has('stop') || has('halt') || has('freeze') || has('estop') || (has('e') && has('stop'));
  if (
    has('emergency') ||
    has('estop') ||
    (stopWord && (has('all') || has('everything') || has('everyone') || has('robots') || has('fleet')))
  ) {
    return { heard, command: { kind: 'stop_all' } };
  }
  if (stopWord && !has('mission')) {
    if (unknown) return { heard, command: { kind: 'stop_all' } }; // a stop is never refused: an unheard robot stops all
    const group = robot ? null : findGroup(w, vocab.groups ?? []); // a robot named is that robot, wherever it is
    if (group) return { heard, command: { kind: 'stop_group', group: group.label, robots: group.robots } };
    const target = robot ?? vocab.selected;
    return { heard, command: target ? { kind: 'stop', robot: target } : { kind: 'stop_all' } };
  }
  if (unknown) return refuse(`no ${unknown} in this fleet (${vocab.robots.join(', ')})`);

  if (rest.length === 1 && ['confirm', 'yes', 'go', 'affirmative', 'execute', 'proceed', 'yeah'].includes(rest[0]))
    return { heard, command: { kind: 'confirm' } };
  if (has('do', 'it') && rest.length <= 2) return { heard, command: { kind: 'confirm' } };
  if ((rest.length === 1 && ['cancel', 'no', 'negative'].includes(rest[0])) || has('never', 'mind'))
    return { heard, command: { kind: 'cancel' } };

  if (hasRest('mission')) {
    /** @type {[string[], 'start' | 'pause' | 'resume' | 'abort'][]} */
    const actions = [
      [['start'], 'start'],
      [['begin'], 'start'],
      [['run'], 'start'],
      [['launch'], 'start'],
      [['pause'], 'pause'],
      [['hold'], 'pause'],
      [['resume'], 'resume'],
      [['continue'], 'resume'],
      [['abort'], 'abort'],
      [['cancel'], 'abort'],
      [['end'], 'abort'],
      [['stop'], 'abort'],
      [['halt'], 'abort'],
    ];
    for (const [seq, action] of actions) if (hasRest(...seq)) return { heard, command: { kind: 'mission', action } };
    return refuse('mission: say start, pause, resume or abort mission');
  }
  if (hasRest('snapshot') || hasRest('picture') || hasRest('photo') || hasRest('capture')) {
    return { heard, command: { kind: 'snapshot', robot: robot ?? vocab.selected } };
  }
  if (hasRest('teleport') || hasRest('take', 'me') || hasRest('bring', 'me') || hasRest('jump')) {
    return robot
      ? { heard, command: { kind: 'teleport', robot } }
      : refuse('teleport: to which robot? say "teleport to robot one"');
  }
  if (
    hasRest('pov') ||
    hasRest('point', 'of', 'view') ||
    hasRest('camera', 'view') ||
    hasRest('robot', 'view') ||
    hasRest('first', 'person')
  ) {
    return { heard, command: { kind: 'view', view: 'pov' } };
  }
  if (
    hasRest('free', 'roam') ||
    hasRest('overview') ||
    hasRest('twin', 'view') ||
    hasRest('free', 'view') ||
    hasRest('map', 'view')
  ) {
    return { heard, command: { kind: 'view', view: 'free_roam' } };
  }
  if (robot && rest.every((t) => SELECT.has(t))) return { heard, command: { kind: 'select', robot } };
  const go = GO.some((seq) => hasRest(...seq)) || (robot !== null && hasRest('to'));
  if (go) {
    const place = findPlace(rest, vocab);
    if (!place) {
      const at = rest.lastIndexOf('to');
      const name = (
        at >= 0
          ? rest.slice(at + 1)
          : rest.filter((t) => !['go', 'drive', 'navigate', 'move', 'head', 'send', 'travel'].includes(t))
      ).join(' ');
      const rooms = vocab.rooms.map((r) => r.title.toLowerCase()).join(', ');
      return refuse(`no room or target called "${name || '?'}" (rooms: ${rooms || 'none'})`);
    }
    const who = robot ?? vocab.selected;
    if (!who) return refuse(`go to ${place.title}: which robot? say "robot one go to ${place.title.toLowerCase()}"`);
    return { heard, command: { kind: 'goto', robot: who, place } };
  }
  return refuse(`not a command: "${heard}" (try "robot one go to corridor", "stop all", "snapshot")`);
}

/** Whether a command makes a robot move (and so waits for a confirmation). @param {VoiceCommand} command */
export function moves(command) {
  return (
    command.kind === 'goto' ||
    (command.kind === 'mission' && (command.action === 'start' || command.action === 'resume'))
  );
}

/** What a command does, for the operator to read. @param {VoiceCommand} command */
export function describe(command) {
  switch (command.kind) {
    case 'select':
      return `select ${command.robot}`;
    case 'goto':
      return `${command.robot} go to ${command.place.title}`;
    case 'stop':
      return `stop ${command.robot}`;
    case 'stop_all':
      return 'stop all robots';
    case 'stop_group':
      return `stop ${command.group}`;
    case 'snapshot':
      return command.robot ? `snapshot of ${command.robot}` : 'snapshot';
    case 'mission':
      return `${command.action} mission`;
    case 'teleport':
      return `teleport to ${command.robot}`;
    case 'view':
      return command.view === 'pov' ? 'Robot POV view' : 'free roam view';
    case 'confirm':
      return 'confirm';
    case 'cancel':
      return 'cancel';
  }
}

/**
 * @typedef {{type: 'run', command: VoiceCommand} | {type: 'ask', command: VoiceCommand, until: number}
 *   | {type: 'say', text: string}} VoiceEffect
 */

/** The confirmation step: motion waits, stops never do, one pending command at a time. */
export class VoiceConfirm {
  /** @type {{command: VoiceCommand, until: number} | null} */
  pending = null;

  /** A phrase was parsed. @param {Parsed} parsed @param {number} now ms @returns {VoiceEffect[]} */
  hear(parsed, now) {
    this.expire(now);
    if (!('command' in parsed)) return [{ type: 'say', text: `heard "${parsed.heard}": ${parsed.refused}` }];
    const { command } = parsed;
    if (command.kind === 'confirm') return this.confirm(now);
    if (command.kind === 'cancel') {
      const had = this.pending;
      this.pending = null;
      return [{ type: 'say', text: had ? `cancelled: ${describe(had.command)}` : 'nothing to cancel' }];
    }
    if (command.kind === 'stop' || command.kind === 'stop_all' || command.kind === 'stop_group') {
      this.pending = null; // a stop overrides whatever motion was waiting
      return [{ type: 'run', command }];
    }
    if (moves(command)) {
      this.pending = { command, until: now + CONFIRM_MS };
      return [{ type: 'ask', command, until: this.pending.until }];
    }
    return [{ type: 'run', command }];
  }

  /** "Confirm" (or, later, a pinch) while a command waits. @param {number} now @returns {VoiceEffect[]} */
  confirm(now) {
    this.expire(now);
    const pending = this.pending;
    this.pending = null;
    return pending ? [{ type: 'run', command: pending.command }] : [{ type: 'say', text: 'nothing to confirm' }];
  }

  /** Drop a confirmation that came too late. @param {number} now @returns {VoiceCommand | null} what lapsed now */
  expire(now) {
    const lapsed = this.pending && now > this.pending.until ? this.pending.command : null;
    if (lapsed) this.pending = null;
    return lapsed;
  }
}
