// @ts-check
/**
 * A schedule as the desktop's form holds it (view/schedule_form.js draws it), and the `schedule/add` or
 * `schedule/update` command it makes. The fields are kept as the inputs give them (text), so that what the operator
 * typed survives a redraw and is read in one place. No DOM: test/schedule_draft.test.js.
 *
 * The page refuses only what it cannot put in a command (no name, a time or a number it cannot read, nothing to run);
 * the schedule's rules (a repeat of at least 60 s, a window with days, hours in order, targets and robots that exist)
 * are the relay's (relay/inspection/schedule_rules.py), whose `error` names the field and is shown beside the form.
 * Times are the browser's local time; a window's hours are the relay's (docs/inspection.md, "Schedules").
 */

/** @typedef {import('./protocol.js').ScheduleDescription} Schedule */
/**
 * A launch window as typed: its weekdays, and the hours `[first, last)`.
 * @typedef {{days: string[], first: string, last: string}} WindowRow
 */
/** A blackout as typed: two local times ('2026-11-30T08:00:00'). @typedef {{start: string, end: string}} BlackoutRow */
/**
 * What a run starts: the targets picked (inspected in that order by `robot`, or by the fleet when `robot` is ''), a
 * mission file of the relay's missions/ directory, or (`kept`) a mission made elsewhere that the form cannot show,
 * kept as it is.
 * @typedef {'targets' | 'file' | 'kept'} MissionKind
 */
/**
 * @typedef {{name: string, what: MissionKind, targets: string[], robot: string, file: string,
 *   kept: Object<string, unknown> | null, missionName: string, start: string, repeat: string, windows: WindowRow[],
 *   blackouts: BlackoutRow[], priority: string, onBusy: 'wait' | 'skip'}} ScheduleDraft
 */
/** What the page cannot send, by the field it is about. @typedef {{field: string, text: string}} Problem */
/**
 * The fields of `schedule/add` (all) or `schedule/update` (those changed), without the id the connection gives.
 * @typedef {Omit<import('./protocol.js').ScheduleAddCommand, 'id'>
 *   | Omit<import('./protocol.js').ScheduleUpdateCommand, 'id'>} ScheduleCommand
 */

export const WEEKDAYS = Object.freeze(['mon', 'tue', 'wed', 'thu', 'fri', 'sat', 'sun']);
/** A new schedule starts this long after the form was opened (s): the operator has a minute to fill it in. */
export const START_AHEAD = 60;
/** The fields `schedule/update` may change, in the order the wire lists them. */
const CHANGEABLE = /** @type {const} */ (['mission', 'start', 'repeat', 'windows', 'blackouts', 'priority', 'on_busy']);

/** @param {number} n */
const two = (n) => String(n).padStart(2, '0');

/**
 * A time as a `datetime-local` input holds it, to the second, in the browser's zone.
 * @param {number} t seconds since the epoch @returns {string}
 */
export function localTime(t) {
  const d = new Date(Math.floor(t) * 1000);
  const day = `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())}`;
  return `${day}T${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
}

/**
 * A `datetime-local` input's text ('2026-11-30T08:00' or with seconds) as seconds since the epoch, or null.
 * @param {string} text @returns {number | null}
 */
export function parseLocal(text) {
  const m = /^(\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2})(?::(\d{2})(?:\.\d+)?)?$/.exec(text.trim());
  if (!m) return null;
  const [year, month, day, hour, minute, second] = m.slice(1).map((v) => Number(v ?? 0));
  const d = new Date(year, month - 1, day, hour, minute, second);
  return d.getMonth() === month - 1 && d.getDate() === day ? d.getTime() / 1000 : null;
}

/**
 * An empty form: every day, all day, repeating hourly, from a minute from now, waiting for a busy robot.
 * @param {number} now seconds since the epoch @returns {ScheduleDraft}
 */
export function newDraft(now) {
  return {
    name: '',
    what: 'targets',
    targets: [],
    robot: '',
    file: '',
    kept: null,
    missionName: '',
    start: localTime(now + START_AHEAD),
    repeat: '60',
    windows: [{ days: [...WEEKDAYS], first: '0', last: '24' }],
    blackouts: [],
    priority: '0',
    onBusy: 'wait',
  };
}

/**
 * The form filled with a schedule the relay listed, to change it.
 * @param {Schedule} schedule @returns {ScheduleDraft}
 */
export function draftOf(schedule) {
  const mission = schedule.mission;
  const steps = Array.isArray(mission.steps) ? mission.steps : null;
  const inspects = steps?.every((s) => s && typeof s === 'object' && Object.keys(s).join() === 'inspect');
  /** @type {Pick<ScheduleDraft, 'what' | 'targets' | 'robot' | 'file' | 'kept'>} */
  let what = { what: 'kept', targets: [], robot: '', file: '', kept: mission };
  if (typeof mission.file === 'string') what = { ...what, what: 'file', file: mission.file, kept: null };
  else if (Array.isArray(mission.targets))
    what = { ...what, what: 'targets', targets: mission.targets.map(String), kept: null };
  else if (steps && inspects && typeof mission.robot === 'string')
    what = { ...what, what: 'targets', targets: steps.map((s) => String(s.inspect)), robot: mission.robot, kept: null };
  return {
    name: schedule.schedule,
    ...what,
    missionName: typeof mission.name === 'string' ? mission.name : '',
    start: localTime(schedule.start),
    repeat: String(schedule.repeat / 60),
    windows: schedule.windows.map((w) => ({ days: [...w.days], first: String(w.hours[0]), last: String(w.hours[1]) })),
    blackouts: schedule.blackouts.map((b) => ({ start: localTime(b.start), end: localTime(b.end) })),
    priority: String(schedule.priority),
    onBusy: schedule.on_busy,
  };
}

/**
 * A number typed in a field, or null when it is not one ('' included).
 * @param {string} text @returns {number | null}
 */
function number(text) {
  const value = text.trim() === '' ? NaN : Number(text);
  return Number.isFinite(value) ? value : null;
}

/**
 * What a draft says, as the wire's fields.
 * @typedef {{mission: Object<string, unknown>, start: number, repeat: number,
 *   windows: {days: string[], hours: number[]}[], blackouts: {start: number, end: number}[], priority: number,
 *   on_busy: 'wait' | 'skip'}} ScheduleFields
 */

/**
 * The fields a draft makes (all of `schedule/add`'s but the name), or what stops it from being sent.
 * @param {ScheduleDraft} draft @returns {{fields: ScheduleFields, problems: Problem[]}}
 */
export function encode(draft) {
  /** @type {Problem[]} */
  const problems = [];
  const named = draft.missionName ? { name: draft.missionName } : {};
  /** @type {Object<string, unknown>} */
  let mission = draft.kept ?? {};
  if (draft.what === 'file') {
    mission = { file: draft.file.trim(), ...named };
    if (!draft.file.trim()) problems.push({ field: 'mission', text: 'give the mission file’s name (e.g. demo)' });
  } else if (draft.what === 'targets') {
    const targets = [...draft.targets];
    mission = draft.robot
      ? { robot: draft.robot, steps: targets.map((t) => ({ inspect: t })), ...named }
      : { targets, ...named };
    if (!targets.length) problems.push({ field: 'mission', text: 'pick the targets its runs inspect' });
  }
  const start = parseLocal(draft.start);
  if (start === null) problems.push({ field: 'start', text: 'give the first run’s date and time' });
  const minutes = number(draft.repeat);
  if (minutes === null) problems.push({ field: 'repeat', text: 'give the minutes between runs' });
  const windows = draft.windows.map((w, n) => {
    const [first, last] = [number(w.first), number(w.last)];
    if (first === null || last === null) problems.push({ field: 'windows', text: `window ${n + 1}: give its hours` });
    return { days: WEEKDAYS.filter((d) => w.days.includes(d)), hours: [first ?? 0, last ?? 0] };
  });
  const blackouts = draft.blackouts.map((b, n) => {
    const [from, to] = [parseLocal(b.start), parseLocal(b.end)];
    if (from === null || to === null)
      problems.push({ field: 'blackouts', text: `blackout ${n + 1}: give its start and end` });
    return { start: from ?? 0, end: to ?? 0 };
  });
  const priority = number(draft.priority);
  if (priority === null) problems.push({ field: 'priority', text: 'give a priority (0: the usual)' });
  const fields = {
    mission,
    start: start ?? 0,
    // Whole seconds: minutes typed as 1.5 are 90 s, and a float such as 0.1 * 60 would read as 6.000000000000001.
    repeat: Math.round((minutes ?? 0) * 60 * 1000) / 1000,
    windows,
    blackouts,
    priority: priority ?? 0,
    on_busy: draft.onBusy,
  };
  return { fields, problems };
}

/**
 * The command a draft makes: `schedule/add` (no `before`), or `schedule/update` with only the fields that differ
 * from the schedule as the relay listed it; or what stops it (nothing changed is one).
 * @param {ScheduleDraft} draft @param {Schedule | null} before the schedule being changed
 * @returns {{command: ScheduleCommand | null, problems: Problem[]}}
 */
export function scheduleCommand(draft, before) {
  const name = draft.name.trim();
  const { fields, problems } = encode(draft);
  if (!name) problems.unshift({ field: 'schedule', text: 'give the schedule a name' });
  if (problems.length) return { command: null, problems };
  if (before === null) {
    const { blackouts, ...rest } = fields;
    const add = /** @type {Omit<import('./protocol.js').ScheduleAddCommand, 'id'>} */ ({
      identifier: 'schedule/add',
      schedule: name,
      ...rest,
      ...(blackouts.length ? { blackouts } : {}),
    });
    return { command: add, problems };
  }
  // Compared as the relay's own schedule would encode, so that a time shown to the second is not a change.
  const was = encode(draftOf(before)).fields;
  /** @type {Record<string, unknown>} */
  const changed = {};
  for (const key of CHANGEABLE)
    if (JSON.stringify(fields[key]) !== JSON.stringify(was[key])) changed[key] = fields[key];
  if (!Object.keys(changed).length)
    return { command: null, problems: [{ field: 'schedule', text: 'nothing changed' }] };
  const update = /** @type {Omit<import('./protocol.js').ScheduleUpdateCommand, 'id'>} */ ({
    identifier: 'schedule/update',
    schedule: before.schedule,
    ...changed,
  });
  return { command: update, problems: [] };
}

/** The form's fields, as the relay's messages name them (the schedule's own name last: every message says it). */
const FIELD_WORDS = /** @type {const} */ ([
  ['mission', /\bmission\b|\btargets?\b|\brobots?\b|\bsteps\b|\bfile\b/],
  ['windows', /\bwindows?\b|\bweekday\b/],
  ['blackouts', /\bblackouts?\b/],
  ['repeat', /\brepeat\b/],
  ['start', /\bstart\b/],
  ['priority', /\bpriority\b/],
  ['on_busy', /\bon_busy\b/],
]);

/**
 * Which field of the form a relay's refusal is about: "schedule/add: repeat must be at least 60 s, got 30.0" is the
 * repeat's. The field quoted (`field 'windows'`) first, then the field word said first after the command's name, and
 * the schedule's name when none is (a name in use, an unknown schedule).
 * @param {string} message @returns {string}
 */
export function fieldOf(message) {
  const quoted = /field '([a-z_]+)/.exec(message)?.[1];
  if (quoted) return quoted;
  const text = message.replace(/^schedule\/[a-z]+:\s*/, '');
  let best = 'schedule';
  let at = Infinity;
  for (const [field, pattern] of FIELD_WORDS) {
    const found = pattern.exec(text);
    if (found && found.index < at) [best, at] = [field, found.index];
  }
  return best;
}

/**
 * @typedef {{request: string, kind: 'change' | 'remove', schedule: string}} Pending a command awaiting its answer
 */

/**
 * The form's state: open or not, the draft, the schedule it changes (Edit) or none (a new one), the command awaiting
 * its answer, and the relay's refusal with the field it names. An `ack` clears and closes the form: the list shows the
 * schedule when the relay's `schedules` message says so (it comes before the `ack`), never before.
 */
export class ScheduleEditor {
  /** The schedule being changed, as the relay listed it when Edit was pressed; null: a new one. */
  /** @type {Schedule | null} */
  before = null;
  /** @type {Pending | null} */
  pending = null;
  /** Why the last command was refused (the relay's message), or what the page could not send; '' when none. */
  error = '';
  /** The field `error` is about ('' when none). */
  field = '';
  /** Whether the form is open (New schedule, or Edit); closed, the panel shows its list and one button. */
  open = false;
  /** Bumped on every change the form must draw (the view keeps what is typed between). */
  version = 0;

  /** @param {number} now seconds since the epoch */
  constructor(now) {
    /** @type {ScheduleDraft} */
    this.draft = newDraft(now);
  }

  /**
   * Open the form for a new schedule, its first run a minute after `now` (not after the page was opened).
   * @param {number} now
   */
  start(now) {
    this.draft = newDraft(now);
    this.before = null;
    this.open = true;
    this.#say('', '');
  }

  /** Fill the form with a listed schedule, to change it. @param {Schedule} schedule */
  edit(schedule) {
    this.draft = draftOf(schedule);
    this.before = schedule;
    this.open = true;
    this.#say('', '');
  }

  /** Empty the form (a new schedule's, from a minute after `now`) and close it. @param {number} now */
  close(now) {
    this.draft = newDraft(now);
    this.before = null;
    this.open = false;
    this.#say('', '');
  }

  /** The command to send for the draft, or null (then `error` says why). @returns {ScheduleCommand | null} */
  submit() {
    if (this.pending) return null;
    const { command, problems } = scheduleCommand(this.draft, this.before);
    if (!command) this.#say(problems.map((p) => p.text).join('; '), problems[0]?.field ?? '');
    return command;
  }

  /**
   * A command went out (request: its id; null: not sent, not connected).
   * @param {string | null} request @param {'change' | 'remove'} kind @param {string} schedule
   */
  sent(request, kind, schedule) {
    if (!request) return;
    this.pending = { request, kind, schedule };
    this.#say('', '');
  }

  /**
   * The answer to the pending command, if it came: an `ack` clears and closes the form (a removal, when it was the
   * one being changed), an `error` is kept with the field it names. Returns whether anything changed.
   * @param {Map<string, boolean>} settled how requests ended (InspectionModel.settled)
   * @param {Map<string, string>} refusals the relay's messages of those refused (InspectionModel.refusals)
   * @param {number} now
   */
  settle(settled, refusals, now) {
    const pending = this.pending;
    const ok = pending ? settled.get(pending.request) : undefined;
    if (!pending || ok === undefined) return false;
    this.pending = null;
    if (!ok) {
      const message = refusals.get(pending.request) ?? 'refused';
      this.#say(message, fieldOf(message));
    } else if (pending.kind === 'change' || this.before?.schedule === pending.schedule) this.close(now);
    else this.version++;
    return true;
  }

  /**
   * The relay's list changed: a schedule being changed that another operator removed is made again by Add.
   * @param {Schedule[]} schedules
   */
  sync(schedules) {
    const before = this.before;
    if (!before || schedules.some((s) => s.schedule === before.schedule)) return;
    this.before = null;
    this.#say(`${before.schedule} was removed meanwhile: Add makes it again`, 'schedule');
  }

  /** A new relay (hello): nothing sent before it will be answered. */
  reset() {
    if (!this.pending) return;
    this.pending = null;
    this.version++;
  }

  /** @param {string} error @param {string} field */
  #say(error, field) {
    this.error = error;
    this.field = field;
    this.version++;
  }
}
