// @ts-check
/**
 * How much a finding's target changed since its previous round, as a pin colour and a few words, and which findings
 * are "what changed since the last round". Pure (no DOM, no three.js): test/change_colour.test.js drives it with the
 * relay's finding messages; view/inspection_view.js applies the colour, the findings panel the filter.
 */
import { statusWords } from './wording.js';

/**
 * Pin colours by status (the report uses the same: relay/inspection/report_html.py). A change is purple, apart from
 * the red of an anomaly and the amber of a finding to review; a false alarm grey, as nothing anyone must act on.
 */
export const STATUS_COLOURS = Object.freeze({
  ok: '#2e9e4f',
  anomaly: '#d62d20',
  needs_review: '#e8a317',
  changed: '#8e44ad',
  false_alarm: '#7f8c8d',
});

/** @typedef {import('./protocol.js').FindingMessage} Finding */

/** The relay's change threshold: a share of the view over it is a change (relay/inspection/change.py). */
export const CHANGE_THRESHOLD = 0.02;
/** A score from which the colour is at its strongest: another place altogether scores over 0.3 (docs/inspection.md). */
export const CHANGE_FULL = 0.3;

/**
 * The changed colour runs from orange (just over the threshold) to magenta (CHANGE_FULL and more), on a log scale of
 * the score: the scores seen are mostly a few percent (a grown spill 0.037), so a linear scale would leave nearly all
 * of them orange. Both ends are saturated and unlit-bright (pins are MeshBasicMaterial), apart from the status
 * colours: not the amber of a finding to review nor the red of an anomaly, and readable under SwiftShader.
 */
export const CHANGE_LOW = '#ff7f00';
export const CHANGE_HIGH = '#ff00ff';

/**
 * Whether the finding says its target changed: `changed`, or a score over the threshold (a false alarm never).
 * @param {Finding} f
 */
export function isChanged(f) {
  if (f.status === 'false_alarm') return false;
  return f.status === 'changed' || (typeof f.change === 'number' && f.change > CHANGE_THRESHOLD);
}

/**
 * How strong the change is, 0 (at the threshold, or a change with no score: a trend) to 1 (CHANGE_FULL or more).
 * @param {number | null} score
 */
export function changeStrength(score) {
  if (typeof score !== 'number' || !(score > CHANGE_THRESHOLD)) return 0;
  const t = Math.log(score / CHANGE_THRESHOLD) / Math.log(CHANGE_FULL / CHANGE_THRESHOLD);
  return Math.min(1, Math.max(0, t));
}

/** @param {string} a @param {string} b @param {number} t '#rrggbb' between a and b */
function mix(a, b, t) {
  const channel = (/** @type {string} */ hex, /** @type {number} */ i) => parseInt(hex.slice(1 + 2 * i, 3 + 2 * i), 16);
  return `#${[0, 1, 2]
    .map((i) => Math.round(channel(a, i) + (channel(b, i) - channel(a, i)) * t))
    .map((v) => v.toString(16).padStart(2, '0'))
    .join('')}`;
}

/**
 * A pin's colour and what it says: the changed scale for a change, grey for a false alarm, else the status colour.
 * @param {Finding} f @returns {{colour: string, label: string}}
 */
export function changeColour(f) {
  if (f.status === 'false_alarm') return { colour: STATUS_COLOURS.false_alarm, label: statusWords(f.status) };
  if (isChanged(f)) {
    const score = typeof f.change === 'number' ? ` ${(f.change * 100).toFixed(1)} %` : '';
    return { colour: mix(CHANGE_LOW, CHANGE_HIGH, changeStrength(f.change)), label: `Changed${score}` };
  }
  return { colour: STATUS_COLOURS[f.status] ?? STATUS_COLOURS.needs_review, label: statusWords(f.status) };
}

/**
 * What changed since the last round: per target (else robot), the newest mission that made a finding about it (by
 * `created`) is its last round; of that mission's findings, those that say their target changed. Findings of no
 * mission (an operator's) are no round's. Keeps the order given.
 * @param {Iterable<Finding>} findings @returns {Finding[]}
 */
export function sinceLastRound(findings) {
  const all = [...findings];
  /** @type {Map<string, {mission: string, created: number}>} */
  const last = new Map();
  for (const f of all) {
    if (!f.mission) continue;
    const key = f.target ?? f.robot;
    const seen = last.get(key);
    if (!seen || f.created > seen.created) last.set(key, { mission: f.mission, created: f.created });
  }
  return all.filter((f) => f.mission && last.get(f.target ?? f.robot)?.mission === f.mission && isChanged(f));
}
