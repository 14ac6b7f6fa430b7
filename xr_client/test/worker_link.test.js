// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { WorkerLink, WorkerSocket } from '../src/worker_link.js';

// Node has no CloseEvent: the proxy only needs its fields.
const g = /** @type {any} */ (globalThis);
g.CloseEvent ??= class extends Event {
  /** @param {string} type @param {{code: number, reason: string, wasClean: boolean}} init */
  constructor(type, init) {
    super(type);
    Object.assign(this, init);
  }
};

class FakeWorker extends EventTarget {
  /** @type {any[]} */
  posted = [];
  terminated = false;
  /** @param {any} message */
  postMessage(message) {
    this.posted.push(message);
  }
  terminate() {
    this.terminated = true;
  }
  /** @param {any} data */
  say(data) {
    this.dispatchEvent(new MessageEvent('message', { data }));
  }
}

function link() {
  const worker = new FakeWorker();
  return { worker, link: new WorkerLink(() => /** @type {any} */ (worker)) };
}

test('a WebSocket-like proxy: opens, sends only while open, passes text and ArrayBuffers, closes with a code', () => {
  const { worker, link: l } = link();
  assert.deepEqual(worker.posted[0], { type: 'init', origin: performance.timeOrigin });
  const socket = l.socket('ws://host/ws?batch=1&token=t');
  assert.deepEqual(worker.posted[1], { type: 'open', id: socket.id, url: 'ws://host/ws?batch=1&token=t' });
  /** @type {any[]} */
  const events = [];
  for (const type of ['open', 'message', 'close'])
    socket.addEventListener(type, (e) =>
      events.push([type, /** @type {any} */ (e).data ?? /** @type {any} */ (e).code ?? null]),
    );
  socket.send('early'); // not open yet: nothing goes out (RelayConnection never does this)
  assert.equal(worker.posted.length, 2);
  worker.say({ type: 'open', id: socket.id });
  assert.equal(socket.readyState, WorkerSocket.OPEN);
  socket.send('{"identifier":"ping","t":1}');
  assert.deepEqual(worker.posted[2], { type: 'send', id: socket.id, data: '{"identifier":"ping","t":1}' });
  const frame = new ArrayBuffer(8);
  worker.say({ type: 'message', id: socket.id, data: '[]' });
  worker.say({ type: 'message', id: socket.id, data: frame });
  worker.say({ type: 'message', id: 99, data: 'another socket' });
  socket.close();
  assert.equal(socket.readyState, WorkerSocket.CLOSING);
  worker.say({ type: 'close', id: socket.id, code: 1001, reason: 'going away', wasClean: true });
  assert.equal(socket.readyState, WorkerSocket.CLOSED);
  assert.deepEqual(events, [
    ['open', null],
    ['message', '[]'],
    ['message', frame],
    ['close', 1001],
  ]);
});

test("the worker clock's news are events; a worker that fails closes its sockets like a lost network", () => {
  const { worker, link: l } = link();
  const socket = l.socket('ws://host/ws');
  /** @type {any[]} */
  const seen = [];
  l.addEventListener('expired', (e) => seen.push(/** @type {CustomEvent} */ (e).detail.silent));
  socket.addEventListener('close', (e) => seen.push(/** @type {any} */ (e).code));
  worker.say({ type: 'expired', identifier: 'robot2/cmd_vel', silent: 1000, epoch: 1 });
  const warn = console.warn;
  console.warn = () => {};
  worker.dispatchEvent(new Event('error', { cancelable: true }));
  console.warn = warn;
  assert.deepEqual(seen, [1000, 1006]);
  assert.ok(l.failed && worker.terminated);
  const before = worker.posted.length;
  l.hold(socket.id, null, 0);
  assert.equal(worker.posted.length, before, 'nothing is posted to a dead worker');
});
