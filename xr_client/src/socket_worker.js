// @ts-check
/**
 * The module worker that owns the page's WebSocket to the relay, so that sending does not wait for the main thread
 * (a software-rendered frame holds it for 100-300 ms), and that runs the teleop sending clock (teleop_hold.js).
 *
 * It is a socket and a clock, nothing more: the page's RelayConnection keeps the reconnect policy, the pings and the
 * parsing (worker_link.js is its WebSocket-like proxy). Frames go out exactly as the page gives them; text frames come
 * in as strings, binary ones as ArrayBuffers transferred, not copied.
 *
 * Page -> worker: {type: 'init', origin} (the page's performance.timeOrigin), {type: 'open', id, url},
 *   {type: 'send', id, data}, {type: 'close', id, code?, reason?}, {type: 'hold', command, epoch}.
 * Worker -> page: {type: 'open', id}, {type: 'message', id, data}, {type: 'close', id, code, reason, wasClean},
 *   {type: 'error', id}, {type: 'sent', zero} (one per cmd_vel this clock sent), {type: 'expired', ...Expiry}.
 */
// Relative imports only: the page's import map does not reach a worker.
import { TeleopHold, stampedText } from './teleop_hold.js';

/**
 * What this file uses of its DedicatedWorkerGlobalScope (the client is type-checked against the DOM library).
 * @typedef {{postMessage(message: unknown, transfer?: Transferable[]): void,
 *   addEventListener(type: 'message', listener: (event: MessageEvent) => void): void}} WorkerScope
 */
const scope = /** @type {WorkerScope} */ (/** @type {unknown} */ (globalThis));

/** @type {Map<number, WebSocket>} */
const sockets = new Map();
/** The socket teleop commands go on: the one the page opened last. */
let current = -1;
/**
 * The page's performance.timeOrigin: cmd_vel.t is on the page's clock (the relay's freshness estimate is per sender).
 */
let pageOrigin = performance.timeOrigin;
const hold = new TeleopHold();
/** @type {ReturnType<typeof setTimeout> | undefined} */
let timer;

/** The page's performance.now(), read from this thread (time origins differ: the worker started later). */
function pageNow() {
  return performance.timeOrigin + performance.now() - pageOrigin;
}

function schedule() {
  clearTimeout(timer);
  const at = hold.wakeAt();
  if (at !== null) timer = setTimeout(run, Math.max(0, at - performance.now()));
}

function run() {
  const { send, expired } = hold.tick(performance.now());
  const socket = sockets.get(current);
  for (const command of send) {
    // Not open (closing, reconnecting): nothing is queued, as for every command; the relay's deadman has the robot.
    if (socket?.readyState !== WebSocket.OPEN) continue;
    socket.send(stampedText(command, pageNow()));
    scope.postMessage({ type: 'sent', zero: command.linear === 0 && command.angular === 0 });
  }
  if (expired) scope.postMessage({ type: 'expired', ...expired });
  schedule();
}

/** @param {number} id @param {string} url */
function open(id, url) {
  hold.drop();
  current = id;
  const socket = new WebSocket(url);
  socket.binaryType = 'arraybuffer';
  sockets.set(id, socket);
  socket.addEventListener('open', () => scope.postMessage({ type: 'open', id }));
  socket.addEventListener('error', () => scope.postMessage({ type: 'error', id }));
  socket.addEventListener('message', (event) => {
    const data = event.data;
    if (data instanceof ArrayBuffer) scope.postMessage({ type: 'message', id, data }, [data]);
    else scope.postMessage({ type: 'message', id, data });
  });
  socket.addEventListener('close', (event) => {
    sockets.delete(id);
    if (id === current) {
      hold.drop();
      schedule();
    }
    scope.postMessage({ type: 'close', id, code: event.code, reason: event.reason, wasClean: event.wasClean });
  });
}

scope.addEventListener('message', (event) => {
  const m = event.data;
  switch (m.type) {
    case 'init':
      pageOrigin = m.origin;
      break;
    case 'open':
      open(m.id, m.url);
      schedule();
      break;
    case 'send': {
      const socket = sockets.get(m.id);
      if (socket?.readyState === WebSocket.OPEN) socket.send(m.data);
      break;
    }
    case 'close':
      sockets.get(m.id)?.close(m.code, m.reason);
      break;
    case 'hold':
      // Only onto the page's current socket, and only while it is open: never onto a newer one.
      if (m.command !== null && (m.id !== current || sockets.get(current)?.readyState !== WebSocket.OPEN)) break;
      hold.hold(m.command, m.epoch, performance.now());
      schedule();
      break;
  }
});
