// @ts-check
/**
 * The WebSocket to the relay. The address comes from the page's own origin (ws:// or wss:// to match),
 * so no host name or IP address is ever written into the client. Commands are never queued while
 * disconnected: `send` returns false and the caller shows it; on reconnect `hello` restores the state.
 */
import { PROTOCOL_VERSION } from './protocol_constants.js';

/** @param {Location | URL} location */
export function relayUrl(location) {
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  return `${scheme}//${location.host}/ws`;
}

export class RelayConnection extends EventTarget {
  /** @param {string} url */
  constructor(url) {
    super();
    this.url = url;
    /** @type {WebSocket | null} */
    this.socket = null;
    this.connected = false;
    this.retryDelay = 0.5;
    this.nextId = 1;
    /** @type {ReturnType<typeof setTimeout> | undefined} */
    this.retryTimer = undefined;
    this.disposed = false;
  }

  connect() {
    const socket = new WebSocket(this.url);
    socket.binaryType = 'arraybuffer';
    this.socket = socket;
    socket.addEventListener('open', () => {
      this.connected = true;
      this.retryDelay = 0.5;
      this.dispatchEvent(new CustomEvent('status', { detail: { connected: true } }));
    });
    socket.addEventListener('message', (event) => {
      if (typeof event.data !== 'string') return; // camera frames: not shown by this page
      const message = JSON.parse(event.data);
      if (message.identifier === 'hello' && message.protocol !== PROTOCOL_VERSION) {
        console.warn(`relay speaks protocol ${message.protocol}, this page ${PROTOCOL_VERSION}`);
      }
      this.dispatchEvent(new CustomEvent('message', { detail: message }));
    });
    socket.addEventListener('close', () => {
      this.connected = false;
      if (this.disposed) return;
      const delay = this.retryDelay;
      this.retryDelay = Math.min(this.retryDelay * 2, 5);
      this.dispatchEvent(new CustomEvent('status', { detail: { connected: false, retryIn: delay } }));
      this.retryTimer = setTimeout(() => this.connect(), delay * 1000);
    });
  }

  /**
   * Send one message; returns its id, or null when disconnected (nothing is queued).
   * @param {Record<string, unknown>} message
   * @param {boolean} [withId]
   */
  send(message, withId = true) {
    if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return null;
    const id = withId ? `r${this.nextId++}` : null;
    this.socket.send(JSON.stringify(withId ? { ...message, id } : message));
    return id;
  }

  dispose() {
    this.disposed = true;
    clearTimeout(this.retryTimer);
    this.socket?.close();
  }
}
