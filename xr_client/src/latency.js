// @ts-check
/**
 * How late what the page shows is, per robot and stage (issue #31: an operator cannot tell whether a picture is 30 ms
 * or 800 ms old): the pose (its stamp to its arrival here), the picture (the publisher's stamp to the picture
 * decoded here, the video benchmark's figure) and the command round trip (sent to the relay's `ack`, which for a goal
 * comes once the backend took it). Stamps are the robots' clocks and the relay's wall clock (`pong.server_time`);
 * the page's clock is mapped onto the relay's by the quickest recent ping (ClockSync, the way NTP picks its sample:
 * the error is at most half that round trip). A stamp from another clock (a recording replayed, a robot whose clock
 * is off by minutes) gives no number rather than a wrong one. Pure: times are passed in; test/latency.test.js.
 */

/** Under this a stage is green; under LATENCY_SLOW_MS amber; above, red (ms). A 20 Hz teleop loop is 50 ms a tick. */
export const LATENCY_OK_MS = 150;
export const LATENCY_SLOW_MS = 500;
/** Samples kept per robot and stage; the number shown is their median (one late frame does not make it jump). */
const SAMPLES = 15;
/** Ages outside this (ms) are clocks that do not compare (a bag's stamps, a robot clock far off): not shown. */
const COMPARABLE_MS = [-250, 120_000];
/** Pings remembered for the clock mapping (every 2 s: the last half minute). */
const PINGS = 15;
/** Commands awaiting their ack, at most (the oldest is forgotten: one that is never answered costs nothing). */
const PENDING = 64;

/** @typedef {'pose' | 'picture' | 'command'} Stage */
/** @typedef {{pose: number | null, picture: number | null, command: number | null}} StageLatency ms, or null */

/** The page's clock (performance.now(), ms) mapped onto the relay's (s), from the pings' pongs. */
export class ClockSync {
  /** @type {{offset: number, rtt: number}[]} */
  #samples = [];
  /** The quickest of them, chosen at each pong (every pose asks). @type {{offset: number, rtt: number} | null} */
  #best = null;

  /**
   * A pong: the ping left at `sent` and its answer came at `received` (page ms); the relay said `serverTime` (s).
   * @param {number} sent @param {number} received @param {number} serverTime
   */
  pong(sent, received, serverTime) {
    if (!(received >= sent) || !Number.isFinite(serverTime)) return;
    this.#samples.push({ offset: serverTime - (sent + received) / 2000, rtt: received - sent });
    if (this.#samples.length > PINGS) this.#samples.shift();
    this.#best = this.#samples.reduce((a, b) => (b.rtt < a.rtt ? b : a));
  }

  /** The relay's time (s) at page time `at` (ms), or null before the first pong. @param {number} at */
  relayTime(at) {
    return this.#best === null ? null : at / 1000 + this.#best.offset;
  }

  /** How far off the mapping may be, ms (half the quickest round trip), or null. */
  get error() {
    return this.#best === null ? null : this.#best.rtt / 2;
  }
}

export class Latency {
  /** @param {ClockSync} clock */
  constructor(clock) {
    this.clock = clock;
    /**
     * `${robot}|${stage}` -> recent samples: a command's round trip (ms), or a pose's or picture's stamp (s) beside
     * its arrival (page ms). Stamped samples are mapped onto the relay's clock when read, by the best ping then: a
     * sample taken while the only pings were slow is not stuck with their error (a CI run's figure stayed 46 ms off
     * the pictures' own, and a pose that seemed 300 ms in the future by an early slow ping was never shown).
     * @type {Map<string, (number | [number, number])[]>}
     */
    this.samples = new Map();
    /** @type {Map<string, {robot: string, at: number}>} command id -> its robot and when it left */
    this.pending = new Map();
  }

  /** A pose stamped `stamp` (s, the robot's clock) arrived at page time `at` (ms). */
  pose(/** @type {string} */ robot, /** @type {number} */ stamp, /** @type {number} */ at) {
    if (Number.isFinite(stamp)) this.#add(robot, 'pose', [stamp, at]);
  }

  /** A picture stamped `stamp` (s, the publisher's clock) became drawable at page time `at` (ms). */
  picture(/** @type {string} */ robot, /** @type {number} */ stamp, /** @type {number} */ at) {
    if (Number.isFinite(stamp)) this.#add(robot, 'picture', [stamp, at]);
  }

  /** A command for `robot` left with `id` at page time `at` (ms). */
  sent(/** @type {string} */ id, /** @type {string} */ robot, /** @type {number} */ at) {
    this.pending.set(id, { robot, at });
    if (this.pending.size > PENDING) this.pending.delete(/** @type {string} */ (this.pending.keys().next().value));
  }

  /** The relay answered command `id` (an `ack`, or an `error`: the round trip is the same) at page time `at`. */
  answered(/** @type {string} */ id, /** @type {number} */ at) {
    const sent = this.pending.get(id);
    if (!sent) return;
    this.pending.delete(id);
    this.#add(sent.robot, 'command', at - sent.at);
  }

  /** A new connection: commands sent before it will not be answered. */
  reset() {
    this.pending.clear();
  }

  /**
   * The robot's latest figures (the median of each stage's recent samples, ms), null where none.
   * @param {string} robot @returns {StageLatency}
   */
  of(robot) {
    return {
      pose: this.#median(robot, 'pose'),
      picture: this.#median(robot, 'picture'),
      command: this.#median(robot, 'command'),
    };
  }

  /** @param {string} robot @param {Stage} stage @param {number | [number, number]} sample */
  #add(robot, stage, sample) {
    const key = `${robot}|${stage}`;
    const list = this.samples.get(key) ?? [];
    list.push(sample);
    if (list.length > SAMPLES) list.shift();
    this.samples.set(key, list);
  }

  /** A sample in ms: a round trip as it is, a stamp's age by the clock mapping now (null: none, or not comparable). */
  #ms(/** @type {number | [number, number]} */ sample) {
    if (typeof sample === 'number') return sample;
    const now = this.clock.relayTime(sample[1]);
    if (now === null) return null;
    const ms = (now - sample[0]) * 1000;
    return ms >= COMPARABLE_MS[0] && ms <= COMPARABLE_MS[1] ? Math.max(0, ms) : null;
  }

  /** @param {string} robot @param {Stage} stage */
  #median(robot, stage) {
    const list = (this.samples.get(`${robot}|${stage}`) ?? []).map((s) => this.#ms(s)).filter((ms) => ms !== null);
    if (list.length === 0) return null;
    const sorted = /** @type {number[]} */ (list).sort((a, b) => a - b);
    const mid = sorted.length >> 1;
    return sorted.length % 2 ? sorted[mid] : (sorted[mid - 1] + sorted[mid]) / 2;
  }
}

/** The colour a figure is drawn in: green, amber or red by LATENCY_OK_MS and LATENCY_SLOW_MS. @param {number} ms */
export function latencyColour(ms) {
  return ms < LATENCY_OK_MS ? '#5ad17a' : ms < LATENCY_SLOW_MS ? '#ffb020' : '#ff5a5a';
}

/**
 * The figures as the panels write them: `[["pose", "35 ms"], ["picture", "120 ms"], ...]`, only the stages measured.
 * @param {StageLatency} figures @returns {{stage: Stage, text: string, colour: string}[]}
 */
export function latencyParts(figures) {
  /** @type {{stage: Stage, text: string, colour: string}[]} */
  const parts = [];
  for (const stage of /** @type {Stage[]} */ (['pose', 'picture', 'command'])) {
    const ms = figures[stage];
    if (ms !== null) parts.push({ stage, text: `${stage} ${formatMs(ms)}`, colour: latencyColour(ms) });
  }
  return parts;
}

/** "35 ms", "1.2 s". @param {number} ms */
export function formatMs(ms) {
  return ms < 1000 ? `${Math.round(ms)} ms` : `${(ms / 1000).toFixed(1)} s`;
}
