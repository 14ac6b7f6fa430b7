// @ts-check
/**
 * The WebSocket to the relay. The address comes from the page's own origin (ws:// or wss:// to match),
 * so no host name or IP address is ever written into the client. Commands are never queued while
 * disconnected: `send` returns null and the caller shows it; on reconnect `hello` restores the state.
 *
 * Events: `status` (the link changed: `detail` is the ReconnectPolicy), `message` (a parsed JSON object),
 * `frame` (a binary frame, a camera's or the 3D map's block records (voxel_map.js): `detail` is its ArrayBuffer).
 *
 * The socket itself lives in a worker when the browser has one (worker_link.js): sending then never waits for the
 * main thread, and the worker repeats the held teleop command at 20 Hz (`hold`) however slow the frames are. The
 * policy here is the same either way; without a worker the socket is a plain WebSocket on this thread.
 */
import { PROTOCOL_VERSION } from './protocol.js';
import { PING_PERIOD_MS, ReconnectPolicy } from './reconnect.js';
import { WorkerSocket, startWorkerLink } from './worker_link.js';

/**
 * The WebSocket address of the relay that served this page, with the operator token when there is one. `batch=1`:
 * this page reads a text frame that is a JSON array of messages (the relay batches state when it is busy).
 * @param {Location | URL} location @param {string | null} [token]
 */
export function relayUrl(location, token = null) {
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  return `${scheme}//${location.host}/ws?batch=1${token ? `&token=${encodeURIComponent(token)}` : ''}`;
}

/**
 * The operator token: the relay prints its address as http://HOST:PORT/#token=TOKEN. A fragment never
 * reaches a server or a log; it is kept for this tab (sessionStorage) so that a reload without it still works.
 * @param {Location | URL} location @param {Pick<Storage, 'getItem' | 'setItem'> | null} storage
 */
export function operatorToken(location, storage) {
  const fromHash = new URLSearchParams(location.hash.replace(/^#/, '')).get('token');
  try {
    if (fromHash) storage?.setItem('xr-relay-token', fromHash);
    return fromHash ?? storage?.getItem('xr-relay-token') ?? null;
  } catch {
    return fromHash; // storage refused (private mode): the fragment still works
  }
}

/**
 * Why the relay would refuse a handshake with this token, or null when it would not (then a failed handshake was
 * the network's doing, and retrying helps). The browser hides the HTTP status of a refused WebSocket handshake;
 * POST /auth answers the same question under the same rules (and the same slowing of wrong tokens).
 * @param {Location | URL} location @param {string | null} token @param {typeof fetch} [fetcher]
 * @returns {Promise<string | null>}
 */
export async function accessRefusal(location, token, fetcher = fetch) {
  try {
    const response = await fetcher(`${location.origin}/auth`, {
      method: 'POST',
      body: token ?? '',
      headers: { 'Content-Type': 'text/plain' },
    });
    if (response.status === 401 || response.status === 403)
      return (await response.text()).trim() || `HTTP ${response.status}`;
    return null;
  } catch {
    return null; // the relay is unreachable: keep trying
  }
}

export class RelayConnection extends EventTarget {
  /**
   * @param {string} url
   * @param {{now?: () => number, refusal?: () => Promise<string | null>,
   *   link?: import('./worker_link.js').WorkerLink | null, clock?: import('./latency.js').ClockSync}} [options]
   *   `refusal` asks why a handshake failed (accessRefusal); a reason stops the retries. `link`: the socket worker
   *   (null: sockets on this thread).
   */
  constructor(url, options = {}) {
    super();
    this.url = url;
    this.now = options.now ?? (() => performance.now());
    this.refusal = options.refusal ?? (async () => null);
    this.link = options.link ?? null;
    /** The page's clock mapped onto the relay's, from the pongs (latency.js). */
    this.clock = options.clock ?? null;
    this.policy = new ReconnectPolicy();
    /** @type {WebSocket | WorkerSocket | null} */
    this.socket = null;
    this.nextId = 1;
    /** @type {ReturnType<typeof setTimeout> | undefined} */
    this.retryTimer = undefined;
    /** @type {ReturnType<typeof setInterval> | undefined} */
    this.pingTimer = undefined;
    this.disposed = false;
    this.messagesIn = 0;
    this.framesIn = 0;
  }

  get connected() {
    return this.socket !== null && this.socket.readyState === WebSocket.OPEN;
  }

  connect() {
    if (this.disposed) return;
    this.policy.connecting(this.now());
    const socket = this.link && !this.link.failed ? this.link.socket(this.url) : new WebSocket(this.url);
    socket.binaryType = 'arraybuffer';
    this.socket = socket;
    socket.addEventListener('open', () => {
      if (socket !== this.socket) return;
      this.policy.opened(this.now());
      this.#status();
    });
    socket.addEventListener('message', (e) => {
      const event = /** @type {MessageEvent} */ (e);
      if (socket !== this.socket) return;
      if (typeof event.data !== 'string') {
        this.framesIn++;
        this.dispatchEvent(new CustomEvent('frame', { detail: event.data }));
        return;
      }
      let parsed;
      try {
        parsed = JSON.parse(event.data);
      } catch {
        console.warn('relay sent a text frame that is not JSON; ignored');
        return;
      }
      // A batch (an array: state messages the relay had waiting for this page) is its messages in order.
      for (const message of Array.isArray(parsed) ? parsed : [parsed]) {
        if (message === null || typeof message !== 'object') continue;
        this.messagesIn++;
        if (message.identifier === 'pong') {
          this.policy.pong(message.t, this.now());
          this.clock?.pong(message.t, this.now(), message.server_time);
          this.#status();
        } else if (message.identifier === 'hello' && message.protocol !== PROTOCOL_VERSION) {
          console.warn(`relay speaks protocol ${message.protocol}, this page ${PROTOCOL_VERSION}`);
        }
        this.dispatchEvent(new CustomEvent('message', { detail: message }));
      }
    });
    let opened = false;
    socket.addEventListener('open', () => {
      opened = true;
    });
    socket.addEventListener('close', () => this.#lost(socket, opened));
    if (this.pingTimer === undefined) {
      this.pingTimer = setInterval(() => this.#ping(), PING_PERIOD_MS);
    }
    this.#status();
  }

  #ping() {
    if (!this.connected) {
      this.#status(); // the countdown moves
      return;
    }
    if (this.policy.stale(this.now()) && this.socket) {
      // The relay went silent without a close (Wi-Fi dropped, a frozen relay): give up on this socket and reconnect
      // now. Its close handshake cannot finish while the other side is silent: the link is lost from this moment.
      const socket = this.socket;
      socket.close();
      this.#lost(socket, true);
      return;
    }
    this.send({ identifier: 'ping', t: this.now() }, false);
  }

  /**
   * A socket is gone (closed, or given up on): the link is down, and a new one is tried after the policy's delay.
   * @param {WebSocket | WorkerSocket} socket @param {boolean} opened whether its handshake had succeeded
   */
  async #lost(socket, opened) {
    if (socket !== this.socket) return;
    this.socket = null;
    if (this.disposed) return;
    const delay = this.policy.closed(this.now());
    this.#status();
    // A handshake that failed may have been refused (a stale token): ask why before knocking again.
    const reason = opened ? null : await this.refusal();
    if (this.disposed || this.socket !== null) return;
    if (reason) {
      this.policy.refused(reason);
      this.#status();
      return;
    }
    this.retryTimer = setTimeout(() => this.connect(), delay);
  }

  #status() {
    this.dispatchEvent(new CustomEvent('status', { detail: this.policy }));
  }

  /** Connect now after a refusal the page has since answered (it signed in: account_flow.js). */
  retry() {
    if (this.disposed || this.socket !== null) return;
    clearTimeout(this.retryTimer);
    this.policy.retry();
    this.connect();
  }

  /**
   * Send one message; returns its id (or '' without one), or null when disconnected: nothing is queued.
   * @param {Record<string, unknown>} message
   * @param {boolean} [withId]
   * @returns {string | null}
   */
  send(message, withId = true) {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return null;
    const id = withId ? `r${this.nextId++}` : '';
    this.socket.send(JSON.stringify(withId ? { ...message, id } : message));
    return id;
  }

  /**
   * Have the socket worker repeat this cmd_vel at 20 Hz (null: stop repeating), confirmed now (teleop_hold.js).
   * Returns whether a worker's clock repeats it: false without a worker or an open socket in one, and then the
   * page's own loop sends every command. A null always reaches the worker.
   * @param {import('./teleop_hold.js').HeldCommand | null} command @param {number} epoch
   */
  hold(command, epoch) {
    if (this.link === null) return false;
    // Whichever socket it repeats onto, also one given up on (a silent relay): stopping never waits for a close.
    if (command === null) this.link.hold(-1, null, epoch);
    const socket = this.socket;
    if (command === null || !(socket instanceof WorkerSocket) || socket.readyState !== WorkerSocket.OPEN) return false;
    this.link.hold(socket.id, command, epoch);
    return true;
  }

  dispose() {
    this.disposed = true;
    clearTimeout(this.retryTimer);
    clearInterval(this.pingTimer);
    this.socket?.close();
    this.socket = null;
    this.link?.dispose();
  }
}

/**
 * The connection to the relay that served this page, with this tab's operator token; a refused token stops
 * the retries (accessRefusal).
 * @param {Location} location @param {Pick<Storage, 'getItem' | 'setItem'> | null} storage
 * @param {import('./latency.js').ClockSync} [clock] fed from the pongs
 */
export function pageConnection(location, storage, clock) {
  const token = operatorToken(location, storage);
  return new RelayConnection(relayUrl(location, token), {
    refusal: () => accessRefusal(location, token),
    link: startWorkerLink(),
    clock,
  });
}
