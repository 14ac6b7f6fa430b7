// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { LatestOnly, parseFrame } from '../src/camera_frame.js';
import { SensorHistory } from '../src/sensor_history.js';
import { PoseSmoother } from '../src/pose_smoother.js';
import { SNAP_ANGLE, SnapTurn, TeleportGesture, smoothVelocity, vignetteStrength } from '../src/locomotion.js';
import { vrAvailability } from '../src/security.js';
import { scanToPoints } from '../src/scan.js';
import { CommandSender } from '../src/command_sender.js';

/** @param {object} header @param {number[]} payload */
function frame(header, payload) {
  const head = new TextEncoder().encode(JSON.stringify(header));
  const buffer = new ArrayBuffer(4 + head.length + payload.length);
  new DataView(buffer).setUint32(0, head.length, false);
  new Uint8Array(buffer, 4).set(head);
  new Uint8Array(buffer, 4 + head.length).set(payload);
  return buffer;
}

test('binary frames: the header says the size, the payload is the rest', () => {
  const header = {
    identifier: 'robot1/camera/front',
    seq: 3,
    stamp: 1.5,
    encoding: 'jpeg',
    width: 640,
    height: 480,
    lens: { model: 'equidistant', fov: 180 },
    request_id: null,
  };
  const { header: h, payload } = parseFrame(frame(header, [0xff, 0xd8, 0xff]));
  assert.deepEqual(h, header);
  assert.deepEqual(Array.from(payload), [0xff, 0xd8, 0xff]);
  assert.throws(() => parseFrame(new ArrayBuffer(2)), /shorter/);
  const bad = frame(header, []);
  new DataView(bad).setUint32(0, 9999, false);
  assert.throws(() => parseFrame(bad), /exceeds/);
  assert.throws(() => parseFrame(frame({ identifier: 'x' }, [])), /width and height/);
});

test('one decode in flight, newest wins', async () => {
  /** @type {number[]} */
  const done = [];
  /** @type {(() => void)[]} */
  const resolvers = [];
  const q = new LatestOnly(async (/** @type {number} */ n) => {
    await new Promise((resolve) => resolvers.push(() => resolve(undefined)));
    done.push(n);
  });
  q.submit(1);
  q.submit(2);
  q.submit(3); // replaces 2
  assert.equal(resolvers.length, 1);
  resolvers[0]();
  await new Promise((r) => setTimeout(r, 0));
  assert.equal(resolvers.length, 2);
  resolvers[1]();
  await new Promise((r) => setTimeout(r, 0));
  assert.deepEqual(done, [1, 3]);
  assert.equal(q.dropped, 1);
  assert.equal(q.busy, false);
});

test('sensor history keeps a minute, draws a sparkline and reports warning crossings once', () => {
  const h = new SensorHistory(60000);
  assert.equal(h.add('robot1', 'gas', 5, false, 0), false);
  assert.equal(h.add('robot1', 'gas', 450, true, 30000), true);
  assert.equal(h.add('robot1', 'gas', 460, true, 31000), false);
  assert.equal(h.robotWarning('robot1'), true);
  h.add('robot1', 'gas', 10, false, 70000);
  assert.deepEqual(h.values('robot1', 'gas').v, [450, 460, 10]);
  assert.equal(h.robotWarning('robot1'), false);
  const { points, min, max } = h.sparkline('robot1', 'gas', 70000, 100, 20);
  assert.equal(min, 10);
  assert.equal(max, 460);
  assert.equal(points.at(-1)?.[0], 100);
  assert.equal(points.at(-1)?.[1], 20);
});

test('pose smoothing: no jump, at most one update behind, far poses snap', () => {
  const s = new PoseSmoother();
  assert.equal(s.sample(0), null);
  s.push(0, 0, 0, 0);
  s.push(0.1, 0, 0, 33);
  assert.deepEqual(s.sample(33), { x: 0, y: 0, yaw: 0 }); // starts where it was drawn
  const mid = /** @type {{x: number}} */ (s.sample(33 + s.interval / 2));
  assert.ok(mid.x > 0.04 && mid.x < 0.06);
  assert.equal(s.sample(33 + s.interval)?.x, 0.1); // caught up within one interval
  s.push(5, 5, 3, 80);
  assert.deepEqual(s.sample(80), { x: 5, y: 5, yaw: 3 });
  // Yaw takes the short way round.
  s.push(5, 5, -3, 110);
  const y = /** @type {{yaw: number}} */ (s.sample(110 + s.interval / 2)).yaw;
  assert.ok(Math.abs(y) > 3, `yaw ${y}`);
});

test('snap turn re-arms past the threshold; the teleport gesture fires once on release', () => {
  const snap = new SnapTurn();
  assert.deepEqual(
    [0.2, 0.8, 0.9, 0.5, 0.2, 0.75].map((x) => snap.update(x)),
    [0, -SNAP_ANGLE, 0, 0, 0, -SNAP_ANGLE],
  );
  assert.equal(snap.update(-0.1), 0);
  assert.equal(snap.update(-0.9), SNAP_ANGLE);
  const tp = new TeleportGesture();
  assert.deepEqual(
    [0, -0.8, -0.9, -0.5, -0.1, 0].map((y) => tp.update(y)),
    ['idle', 'aim', 'aim', 'aim', 'teleport', 'idle'],
  );
});

test('smooth locomotion follows the heading; the vignette fades in fast and out slowly', () => {
  const [vx, vz] = smoothVelocity(0, -1, 0);
  assert.ok(Math.abs(vx) < 1e-12 && vz < 0); // forward is -z
  const [rx, rz] = smoothVelocity(0, -1, Math.PI / 2); // facing -x
  assert.ok(rx < 0 && Math.abs(rz) < 1e-9);
  assert.deepEqual(smoothVelocity(0.1, 0.1, 0), [0, 0]);
  const up = vignetteStrength(0, 1.5, 0, 0.05);
  const down = vignetteStrength(1, 0, 0, 0.05);
  assert.ok(up > 0.3 && 1 - down < 0.15);
});

test('VR availability says why and how to fix it', () => {
  const lan = vrAvailability({ secure: false, hostname: '192.168.1.20', port: '8080', hasXR: true, vrSupported: null });
  assert.equal(lan.available, false);
  assert.match(lan.reason, /secure context/);
  assert.match(lan.fix, /--tls auto/);
  assert.match(lan.fix, /adb reverse tcp:8080 tcp:8080/);
  assert.equal(
    vrAvailability({ secure: false, hostname: '127.0.0.1', port: '8080', hasXR: true, vrSupported: true }).available,
    true,
  );
  assert.match(
    vrAvailability({ secure: true, hostname: 'x', port: '', hasXR: false, vrSupported: null }).reason,
    /no WebXR/,
  );
});

test('scans: LaserScan-like ranges or points, in the robot frame', () => {
  const out = new Float32Array(16);
  const n = scanToPoints({ angle_min: 0, angle_increment: Math.PI / 2, ranges: [1, null, 2, 99], range_max: 10 }, out);
  assert.equal(n, 2);
  assert.deepEqual(
    Array.from(out.slice(0, 4)).map((v) => Math.round(v * 1e6) / 1e6),
    [1, 0, -2, 0],
  );
  assert.equal(
    scanToPoints(
      {
        points: [
          [1, 2],
          [3, 'x'],
          [5, 6],
        ],
      },
      out,
    ),
    2,
  );
  assert.equal(scanToPoints({}, out), 0);
});

test('frame timing: a fixed ring, recent samples in order, quantiles', async () => {
  const { FrameTimer } = await import('../src/frame_timer.js');
  const t = new FrameTimer(4);
  assert.deepEqual(t.stats(), { samples: 0, p50: null, p95: null, p99: null, max: null });
  [1, 2, 3, 4, 5, 6].forEach((ms) => t.record(ms));
  assert.deepEqual(t.recent(3), [4, 5, 6]);
  assert.deepEqual(t.recent(10), [3, 4, 5, 6]);
  assert.equal(t.stats().samples, 4);
  assert.equal(t.stats().max, 6);
  assert.equal(t.stats().p50, 5);
});

test('every cmd_vel carries the client clock as t, so the relay can drop a command that waited', () => {
  /** @type {Record<string, unknown>[]} */
  const sent = [];
  let now = 1234.4;
  const sender = new CommandSender(
    { send: (m) => (sent.push(m), '') },
    () => {},
    () => now,
  );
  sender.twist({ robot: 'robot1', linear: 0.2, angular: -0.1 });
  now = 1284.6;
  sender.twist({ robot: 'robot1', linear: 0, angular: 0 });
  assert.deepEqual(
    sent.map((m) => m.t),
    [1234, 1285],
  );
  assert.deepEqual(Object.keys(sent[0]).sort(), ['angular', 'identifier', 'linear', 't']);
});

test('a stream asked as H.264 that the relay refuses, then or later, is told to the feed; JPEG ones are not', () => {
  /** @type {any[]} */
  const refused = [];
  let n = 0;
  const sender = new CommandSender({ send: () => `r${++n}` }, () => {});
  sender.onVideoRefused = (error) => refused.push(error.message);
  const video = sender.stream('robot1', 'front', 15, 'h264');
  const jpeg = sender.stream('robot1', 'front', 15, 'jpeg');
  sender.failed({ identifier: 'error', id: jpeg, code: 'unsupported', message: 'no' });
  assert.deepEqual(refused, []);
  sender.failed({ identifier: 'error', id: video, code: 'unsupported', message: 'robot1/stream: 641x480' });
  sender.failed({ identifier: 'error', id: video, code: 'unsupported', message: 'answered once' });
  sender.acked(sender.stream('robot1', 'front', 15, 'h264') ?? '');
  sender.failed({ identifier: 'error', id: null, code: 'unsupported', message: 'robot1/camera/front: encoder failed' });
  assert.deepEqual(refused, ['robot1/stream: 641x480', 'robot1/camera/front: encoder failed']);
});
