// @ts-check
/**
 * The page's side of the socket worker (socket_worker.js): `WorkerLink` starts the worker and gives out
 * `WorkerSocket`s, small WebSocket-like proxies of the worker's sockets (readyState, send, close; open, message,
 * close and error events, a close with its code and reason), so that RelayConnection keeps its reconnect policy,
 * pings and parsing whichever thread holds the socket. It also carries the teleop hold to the worker's clock and
 * that clock's news back (`sent`, `expired` events).
 *
 * A worker that cannot start (no module workers, a blocked script) fails its sockets as a network error would
 * (close 1006) and says `failed`: the connection's next attempt uses a WebSocket on the main thread, today's path.
 */

/** @typedef {import('./teleop_hold.js').HeldCommand} HeldCommand */

export class WorkerSocket extends EventTarget {
  static CONNECTING = 0;
  static OPEN = 1;
  static CLOSING = 2;
  static CLOSED = 3;

  /** @param {WorkerLink} link @param {number} id @param {string} url */
  constructor(link, id, url) {
    super();
    this.link = link;
    this.id = id;
    this.url = url;
    /** Always: the worker receives binary frames as ArrayBuffers (and transfers them here). */
    this.binaryType = 'arraybuffer';
    /** @type {number} */
    this.readyState = WorkerSocket.CONNECTING;
  }

  /**
   * Like WebSocket.send; nothing goes out unless open (the worker checks its socket again).
   * @param {string | ArrayBuffer} data
   */
  send(data) {
    if (this.readyState === WorkerSocket.OPEN) this.link.post({ type: 'send', id: this.id, data });
  }

  /** @param {number} [code] @param {string} [reason] */
  close(code, reason) {
    if (this.readyState >= WorkerSocket.CLOSING) return;
    this.readyState = WorkerSocket.CLOSING;
    this.link.post({ type: 'close', id: this.id, code, reason });
  }

  /** What the worker said of this socket. @param {any} m */
  receive(m) {
    switch (m.type) {
      case 'open':
        this.readyState = WorkerSocket.OPEN;
        this.dispatchEvent(new Event('open'));
        break;
      case 'message':
        this.dispatchEvent(new MessageEvent('message', { data: m.data }));
        break;
      case 'error':
        this.dispatchEvent(new Event('error'));
        break;
      case 'close':
        this.readyState = WorkerSocket.CLOSED;
        this.dispatchEvent(new CloseEvent('close', { code: m.code, reason: m.reason, wasClean: m.wasClean }));
        break;
    }
  }
}

export class WorkerLink extends EventTarget {
  /** @param {() => Worker} [start] */
  constructor(start = () => new Worker(new URL('./socket_worker.js', import.meta.url), { type: 'module' })) {
    super();
    /** The worker could not start or died: sockets are made on the main thread from now on. */
    this.failed = false;
    this.nextId = 1;
    /** @type {Map<number, WorkerSocket>} */
    this.sockets = new Map();
    this.worker = start();
    this.worker.addEventListener('message', this.#onMessage);
    this.worker.addEventListener('error', this.#onError);
    // cmd_vel.t is stamped on this page's performance.now(): the worker converts its own clock with the two origins.
    this.post({ type: 'init', origin: performance.timeOrigin });
  }

  /** A new socket to `url`, opened by the worker. @param {string} url */
  socket(url) {
    const socket = new WorkerSocket(this, this.nextId++, url);
    this.sockets.set(socket.id, socket);
    this.post({ type: 'open', id: socket.id, url });
    return socket;
  }

  /**
   * What the worker's clock repeats on the socket `id` (null: nothing, whichever socket), confirmed now.
   * @param {number} id @param {HeldCommand | null} command @param {number} epoch
   */
  hold(id, command, epoch) {
    this.post({ type: 'hold', id, command, epoch });
  }

  /** @param {Record<string, unknown>} message */
  post(message) {
    if (!this.failed) this.worker.postMessage(message);
  }

  /** @param {MessageEvent} event */
  #onMessage = (event) => {
    const m = event.data;
    if (m.type === 'sent' || m.type === 'expired') {
      this.dispatchEvent(new CustomEvent(m.type, { detail: m }));
      return;
    }
    const socket = this.sockets.get(m.id);
    if (m.type === 'close') this.sockets.delete(m.id);
    socket?.receive(m);
  };

  /** @param {Event} event */
  #onError = (event) => {
    event.preventDefault();
    console.warn('the socket worker failed; the connection runs on the page from now on');
    this.failed = true;
    this.worker.terminate();
    for (const socket of this.sockets.values())
      socket.receive({ type: 'close', code: 1006, reason: 'socket worker failed', wasClean: false });
    this.sockets.clear();
  };

  dispose() {
    this.worker.removeEventListener('message', this.#onMessage);
    this.worker.removeEventListener('error', this.#onError);
    this.worker.terminate();
    this.sockets.clear();
  }
}

/** A link to a socket worker, or null where the browser has no module workers (the main thread's sockets then). */
export function startWorkerLink() {
  if (typeof Worker === 'undefined') return null;
  try {
    return new WorkerLink();
  } catch (error) {
    console.warn('no socket worker; the connection runs on the page', error);
    return null;
  }
}
