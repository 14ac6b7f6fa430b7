// @ts-check
/**
 * Connection behaviour without sockets: the reconnect schedule (exponential backoff with a cap, reset by a
 * connection that lasted), the status line the operator always sees, and latency from ping/pong.
 * Times are milliseconds from any monotonic clock (performance.now()).
 */

export const FIRST_RETRY_MS = 500;
export const MAX_RETRY_MS = 5000;
export const PING_PERIOD_MS = 2000;
/** No pong for this long: the link is dead even if the socket has not noticed (Wi-Fi roaming). */
export const PONG_TIMEOUT_MS = 6000;
/**
 * A check later than its period by more than this (ms) finds a page that could not listen meanwhile (a long frame, a
 * glTF being parsed): the pongs that came are still queued behind the check, so that time is not the relay's silence.
 * A CI run's page, drawing a 3D map on SwiftShader at a load of 15, missed its pongs for 6 s this way and dropped a
 * live link.
 */
export const STALL_MS = 500;

/** @typedef {'connecting' | 'connected' | 'reconnecting' | 'refused'} LinkState */

export class ReconnectPolicy {
  /** @param {{first?: number, max?: number}} [options] */
  constructor(options = {}) {
    this.first = options.first ?? FIRST_RETRY_MS;
    this.max = options.max ?? MAX_RETRY_MS;
    /** @type {LinkState} */
    this.state = 'connecting';
    this.delay = this.first;
    /** @type {number | null} */
    this.retryAt = null;
    this.attempts = 0;
    /** @type {number | null} */
    this.latency = null;
    /** @type {number | null} */
    this.lastPong = null;
    /** When the link was last checked (stale), and how long the page could not listen since the last pong (ms). */
    /** @type {number | null} */
    this.lastCheck = null;
    this.deaf = 0;
    /** @type {number | null} */
    this.openedAt = null;
    this.everOpened = false;
    /** Why the relay refuses this page (its token): set, no more attempts are made. */
    this.refusal = '';
  }

  /**
   * The relay refused the handshake and said why (POST /auth): retrying cannot help, so nothing is retried and
   * the operator is told what to do. A token that was wrong stays wrong.
   * @param {string} reason
   */
  refused(reason) {
    this.state = 'refused';
    this.refusal = reason;
    this.retryAt = null;
  }

  /** The refusal was answered (the page signed in): connect again from the start. */
  retry() {
    this.state = 'connecting';
    this.refusal = '';
    this.attempts = 0;
    this.delay = this.first;
  }

  /** A socket is being opened. @param {number} now */
  connecting(now) {
    this.attempts++;
    this.retryAt = null;
    if (this.state !== 'reconnecting') this.state = 'connecting';
    return now;
  }

  /** The socket opened (the relay's hello follows). @param {number} now */
  opened(now) {
    this.state = 'connected';
    this.everOpened = true;
    this.openedAt = now;
    this.lastPong = now;
    this.lastCheck = null;
    this.deaf = 0;
    this.retryAt = null;
  }

  /**
   * The socket closed: when to try again (ms from now). The delay doubles up to the cap, and starts over
   * once a connection has stayed up for a while.
   * @param {number} now
   */
  closed(now) {
    if (this.openedAt !== null && now - this.openedAt > 10000) this.delay = this.first;
    const delay = this.delay;
    this.delay = Math.min(this.delay * 2, this.max);
    this.state = 'reconnecting';
    this.openedAt = null;
    this.latency = null;
    this.retryAt = now + delay;
    return delay;
  }

  /** A pong echoing the `t` of our ping. @param {number} t @param {number} now */
  pong(t, now) {
    const sample = Math.max(0, now - t);
    // A light moving average: one slow frame does not make the number jump.
    this.latency = this.latency === null ? sample : this.latency * 0.7 + sample * 0.3;
    this.lastPong = now;
    this.deaf = 0;
  }

  /**
   * Whether the open link has gone silent past PONG_TIMEOUT_MS, asked every PING_PERIOD_MS: the time the page itself
   * could not listen (a check later than that by over STALL_MS) is not counted.
   * @param {number} now
   */
  stale(now) {
    if (this.lastCheck !== null) this.deaf += Math.max(0, now - this.lastCheck - PING_PERIOD_MS - STALL_MS);
    this.lastCheck = now;
    return this.state === 'connected' && this.lastPong !== null && now - this.lastPong - this.deaf > PONG_TIMEOUT_MS;
  }

  /** The status line: "connected · 12 ms", "reconnecting in 3 s", "connecting…". @param {number} now */
  describe(now) {
    if (this.state === 'refused' && this.refusal.startsWith('sign in')) return 'sign in to connect';
    if (this.state === 'refused')
      return `refused: ${this.refusal} · open the address the relay printed (…/#token=…) and reload`;
    if (this.state === 'connected')
      return this.latency === null ? 'connected' : `connected · ${Math.round(this.latency)} ms`;
    if (this.state === 'reconnecting' && this.retryAt !== null) {
      const countdown = `reconnecting in ${Math.max(0, Math.ceil((this.retryAt - now) / 1000))} s`;
      // A relay that refuses every attempt usually wants its operator token (the browser cannot see why).
      if (!this.everOpened && this.attempts >= 3)
        return `cannot connect · ${countdown} · open the address the relay printed (…/#token=…)`;
      return `disconnected · ${countdown}`;
    }
    return this.attempts > 1 ? 'reconnecting…' : 'connecting…';
  }
}
