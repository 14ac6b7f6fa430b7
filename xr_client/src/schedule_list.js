// @ts-check
/**
 * The schedules as the desktop lists them (docs/inspection.md, "Schedules"): what each runs, when its next run is,
 * what became of its last run, and its state in words, from the relay's `schedules` message. No DOM: the findings
 * panel (view/findings_panel.js) draws the rows; test/schedule_list.test.js checks them.
 */

/**
 * @typedef {import('./protocol.js').ScheduleDescription} Schedule
 * @typedef {{name: string, what: string, next: string, last: string, state: string, tone: 'ok' | 'warning'}}
 *   ScheduleRow
 */

/**
 * A time in words on the operator's clock (`timeZone` for tests: the zone to read it in).
 * @param {number} t seconds since the epoch @param {string} [timeZone] @returns {string}
 */
export function when(t, timeZone) {
  // From the parts, not the whole string: ICU versions punctuate en-GB differently ("Mon, 30 Nov" or "Mon 30 Nov").
  const parts = new Intl.DateTimeFormat('en-GB', {
    weekday: 'short',
    day: '2-digit',
    month: 'short',
    hour: '2-digit',
    minute: '2-digit',
    hourCycle: 'h23',
    timeZone,
  }).formatToParts(new Date(t * 1000));
  /** @param {Intl.DateTimeFormatPartTypes} type */
  const part = (type) => parts.find((p) => p.type === type)?.value ?? '';
  return `${part('weekday')} ${part('day')} ${part('month')} ${part('hour')}:${part('minute')}`;
}

/** What a schedule's runs start, in words. @param {Schedule['mission']} mission @returns {string} */
export function missionWords(mission) {
  const named = typeof mission.name === 'string' ? `${mission.name}: ` : '';
  if (typeof mission.file === 'string') return `${named}mission file ${mission.file}`;
  if (Array.isArray(mission.targets)) return `${named}${mission.targets.join(', ')} (the fleet)`;
  const steps = Array.isArray(mission.steps) ? mission.steps.length : 0;
  return `${named}${steps} step${steps === 1 ? '' : 's'} for ${String(mission.robot)}`;
}

/**
 * The rows of the desktop's schedule list, by name.
 * @param {Schedule[]} schedules @param {string} [timeZone] @returns {ScheduleRow[]}
 */
export function scheduleRows(schedules, timeZone) {
  return [...schedules]
    .sort((a, b) => (a.schedule < b.schedule ? -1 : a.schedule > b.schedule ? 1 : 0))
    .map((s) => {
      const last = s.last_run;
      const lastWords = last
        ? `${last.outcome} ${when(last.slot, timeZone)}${last.reason ? `: ${last.reason}` : ''}`
        : 'no run yet';
      const state = s.state === 'waiting' ? `waiting: ${s.reason}` : s.state;
      const failed = last !== null && last.outcome !== 'started';
      return {
        name: s.schedule,
        what: missionWords(s.mission),
        next: s.next_run === null ? 'none' : when(s.next_run, timeZone),
        last: lastWords,
        state,
        tone: failed || s.state === 'waiting' ? 'warning' : 'ok',
      };
    });
}
