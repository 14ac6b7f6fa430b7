// @ts-check
/**
 * Inspection as the relay reports it: targets, missions (one per robot), findings and the alerts nobody acknowledged
 * yet, kept by id, with what the operator is told when a mission changes state or an alert is raised. No DOM, no
 * WebGL: test/inspection_model.test.js drives it with the relay's message shapes. Views (view/inspection_view.js,
 * the findings list) read it.
 */
import { count } from './wording.js';
import { sinceLastRound } from './change_colour.js';

/**
 * @typedef {import('./protocol.js').TargetDescription} Target
 * @typedef {import('./protocol.js').MissionMessage} Mission
 * @typedef {import('./protocol.js').FindingMessage} Finding
 * @typedef {import('./protocol.js').RegionMessage} Region
 * @typedef {import('./protocol.js').AlertMessage} Alert
 * @typedef {import('./protocol.js').ScheduleDescription} Schedule
 * @typedef {import('./protocol.js').FindingStatus} FindingStatus
 * @typedef {{text: string, kind: 'info' | 'warning' | 'error'}} InspectionNotice
 */

/** Seconds an alert is news: one raised longer ago (sent again after a reconnect) is listed, not told. */
export const FRESH_ALERT = 120;

export class InspectionModel {
  /** @type {Map<string, Target>} */
  targets = new Map();
  /** @type {Map<string, Mission>} */
  missions = new Map();
  /** @type {Map<string, Finding>} */
  findings = new Map();
  /** Alerts nobody acknowledged yet, by id; an acknowledged one leaves. @type {Map<string, Alert>} */
  alerts = new Map();
  /** The schedules, as the relay's newest `schedules` message lists them. @type {Schedule[]} */
  schedules = [];
  /** Outlines the relay segmented, by the request id that asked (region). @type {Map<string, number[][]>} */
  regions = new Map();
  /** Requests the review waits on (a target from the live image), until their ack or error. @type {Set<string>} */
  awaiting = new Set();
  /** How each awaited request ended (true: ack), the newest few. @type {Map<string, boolean>} */
  settled = new Map();
  /** The relay's message for each awaited request it refused (the schedule form shows it). */
  /** @type {Map<string, string>} */
  refusals = new Map();
  /** Bumped on every change, so views redraw only when something changed. */
  version = 0;
  /**
   * The findings history beyond those the relay sent at connect: `unknown` (none asked yet), `asked` (a page is on
   * its way), `more` (older ones remain), `all` (the oldest is here).
   * @type {'unknown' | 'asked' | 'more' | 'all'}
   */
  history = 'unknown';
  /** Show only what changed since each target's last round (change_colour.js): the pins and the panel's rows. */
  sinceLastRound = false;

  /**
   * Apply one inspection message; returns what the operator should be told (nothing for most).
   * @param {import('./protocol.js').TargetsMessage | import('./protocol.js').TargetsChangedMessage | Mission | Finding
   *   | Region | import('./protocol.js').FindingsMessage | Alert | import('./protocol.js').SchedulesMessage} message
   * @returns {InspectionNotice[]}
   */
  apply(message) {
    this.version++;
    switch (message.identifier) {
      case 'targets':
        this.targets = new Map(message.targets.map((t) => [t.id, t]));
        return [];
      case 'targets_changed': // what changed since the whole list came with the hello
        for (const id of message.removed) this.targets.delete(id);
        for (const target of message.added) this.targets.set(target.id, target);
        return [];
      case 'mission':
        return this.#mission(message);
      case 'finding': {
        const known = this.findings.has(message.id);
        this.findings.set(message.id, message);
        if (known || message.status !== 'anomaly') return [];
        return [{ text: `Finding at ${message.target ?? message.robot}: ${message.note}`, kind: 'warning' }];
      }
      case 'region':
        this.regions.set(String(message.id), message.outline);
        return [];
      case 'findings': // a page of the history, asked for: no notices for old news
        for (const finding of message.findings) this.findings.set(finding.id, finding);
        this.history = message.more ? 'more' : 'all';
        return [];
      case 'alert':
        return this.#alert(message);
      case 'schedules': // the whole list, on every change: they are few (at most 100)
        this.schedules = message.schedules;
        return [];
    }
  }

  /** @param {() => number} [wall] seconds since the epoch: how old an alert is when it arrives */
  constructor(wall = () => Date.now() / 1000) {
    this.wall = wall;
  }

  /**
   * An alert raised (told at once, unless it is old news: the open alerts the relay sends after each hello are in
   * the list and its badge, not in as many notices) or acknowledged (it leaves the list).
   * @param {Alert} alert @returns {InspectionNotice[]}
   */
  #alert(alert) {
    if (alert.acknowledged) {
      // Acknowledged by someone (this operator, or another): it leaves every list; the one who did it knows.
      this.alerts.delete(alert.alert);
      return [];
    }
    const known = this.alerts.has(alert.alert);
    this.alerts.set(alert.alert, alert);
    return known || this.wall() - alert.raised > FRESH_ALERT
      ? []
      : [{ text: `Alert: ${alert.text}`, kind: alert.severity === 'critical' ? 'error' : 'warning' }];
  }

  /** The alerts to acknowledge, newest first. @returns {Alert[]} */
  openAlerts() {
    return [...this.alerts.values()].sort((a, b) => b.raised - a.raised);
  }

  /** The oldest finding's `created`: where the next page of the history starts. @returns {number | null} */
  oldest() {
    let oldest = null;
    for (const f of this.findings.values()) if (oldest === null || f.created < oldest) oldest = f.created;
    return oldest;
  }

  /** @param {Mission} mission @returns {InspectionNotice[]} */
  #mission(mission) {
    const before = this.missions.get(mission.id);
    this.missions.set(mission.id, mission);
    if (before?.state === mission.state) return [];
    const why = mission.reason ? `: ${mission.reason}` : '';
    switch (mission.state) {
      case 'paused':
        return [{ text: `${mission.robot}'s mission paused${why}`, kind: 'warning' }];
      case 'aborted':
        return [{ text: `${mission.robot}'s mission aborted${why}`, kind: 'error' }];
      case 'done':
        return [{ text: `${mission.robot}'s mission done (${count(mission.steps.length, 'step')})`, kind: 'info' }];
      default:
        return before ? [{ text: `${mission.robot}'s mission running again`, kind: 'info' }] : [];
    }
  }

  /** The mission a robot is on (running or paused), if any. @param {string} robot */
  active(robot) {
    for (const mission of this.missions.values()) {
      if (mission.robot === robot && (mission.state === 'running' || mission.state === 'paused')) return mission;
    }
    return null;
  }

  /** One line for the sensor panel or the menu: "mission: step 2 of 3 (inspect spill)". @param {string} robot */
  progress(robot) {
    const mission = this.active(robot);
    if (!mission) return '';
    const step = mission.steps[mission.current];
    const what = step ? `${step.kind}${step.target ? ` ${step.target}` : ''}` : 'finishing';
    const state = mission.state === 'paused' ? ` · paused${mission.reason ? `: ${mission.reason}` : ''}` : '';
    const number = Math.min(mission.current + 1, mission.steps.length);
    return `mission: step ${number} of ${mission.steps.length} (${what})${state}`;
  }

  /**
   * Findings, newest first, filtered by status and robot (null: all).
   * @param {{status?: FindingStatus | null, robot?: string | null}} [filter]
   */
  list(filter = {}) {
    return [...this.findings.values()]
      .filter(
        (f) => (filter.status ? f.status === filter.status : true) && (filter.robot ? f.robot === filter.robot : true),
      )
      .sort((a, b) => b.created - a.created);
  }

  /**
   * The findings shown (pins, the panel's rows): `list`, and only what changed since the last round while that
   * switch is on. @param {{status?: FindingStatus | null, robot?: string | null}} [filter]
   */
  visible(filter = {}) {
    if (!this.sinceLastRound) return this.list(filter);
    const changed = new Set(sinceLastRound(this.findings.values()).map((f) => f.id));
    return this.list(filter).filter((f) => changed.has(f.id));
  }

  /** Turn "since last round" on or off (the desktop panel's switch, the VR menu's button). @param {boolean} on */
  setSinceLastRound(on) {
    if (on === this.sinceLastRound) return;
    this.sinceLastRound = on;
    this.version++;
  }

  /** Wait for a request's answer (`settle`). @param {string} request */
  await(request) {
    this.awaiting.add(request);
  }

  /**
   * An `ack` (ok) or `error` arrived: whether it answered a request a view waits on (then views update).
   * @param {string} request @param {boolean} ok @param {string} [message] the error's, naming what was wrong
   */
  settle(request, ok, message = '') {
    if (!this.awaiting.delete(request)) return false;
    this.settled.set(request, ok);
    if (!ok) this.refusals.set(request, message);
    for (const old of this.settled.keys()) if (this.settled.size > 16) this.settled.delete(old);
    for (const old of this.refusals.keys()) if (!this.settled.has(old)) this.refusals.delete(old);
    this.version++;
    return true;
  }

  /** A new relay (hello after a reconnect): what it sends next replaces everything. */
  reset() {
    this.awaiting.clear();
    this.settled.clear();
    this.refusals.clear();
    this.targets.clear();
    this.missions.clear();
    this.findings.clear();
    this.alerts.clear();
    this.schedules = [];
    this.regions.clear();
    this.history = 'unknown';
    this.version++;
  }
}
