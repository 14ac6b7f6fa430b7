// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Freshness, MIN_STALE_MS, formatSilence } from '../src/freshness.js';

test('each source is judged by its own rate: a 30 Hz pose goes stale in a second, a 1 Hz sensor after three', () => {
  const f = new Freshness();
  for (let t = 0; t <= 1000; t += 33) f.seen('robot1', t);
  for (let t = 0; t <= 10000; t += 1000) f.seen('robot1/gas', t);
  assert.equal(f.limit('robot1'), MIN_STALE_MS, 'three 33 ms intervals is below the floor');
  assert.equal(f.stale('robot1', 990 + 900), false);
  assert.equal(f.stale('robot1', 990 + 1100), true);
  assert.equal(f.limit('robot1/gas'), 3000);
  assert.equal(f.stale('robot1/gas', 10000 + 2500), false);
  assert.equal(f.stale('robot1/gas', 10000 + 3500), true);
  assert.equal(f.stale('never', 1e9), false, 'never seen is unknown, not stale');
  assert.equal(f.age('never', 5), null);
});

test('one late arrival does not teach a slow rate (the median), and a reset forgets the old relay', () => {
  const f = new Freshness();
  for (let t = 0; t <= 2000; t += 100) f.seen('r', t);
  f.seen('r', 9000); // a 7 s hole (a frozen relay)
  f.seen('r', 9100);
  assert.equal(f.usual('r'), 100);
  assert.equal(f.stale('r', 9100 + 1200), true);
  f.reset();
  assert.equal(f.age('r', 10000), null);
  assert.equal(formatSilence(400), '1 s');
  assert.equal(formatSilence(2345), '2 s');
  assert.equal(formatSilence(45900), '45 s');
  assert.equal(formatSilence(600000), '10 min');
});

test('a sparkline breaks where the readings stopped, not at every late one', async () => {
  const { gaps, SensorHistory } = await import('../src/sensor_history.js');
  const t = [0, 200, 400, 600, 5600, 5800, 6000];
  assert.deepEqual(gaps(t), [4], 'a 5 s hole in 5 Hz readings');
  assert.deepEqual(gaps([0, 1000, 2000, 3500, 4500]), [], 'a 1.5 s pause of a 1 Hz sensor is no gap');
  const h = new SensorHistory();
  for (const x of t) h.add('robot1', 'gas', 1, false, x);
  assert.deepEqual(h.sparkline('robot1', 'gas', 6000, 100, 20).breaks, [4]);
});

test('a quiet relay makes the panel say every reading is old, with its age; a reconnect is said', async () => {
  const { MessageRouter } = await import('../src/message_router.js');
  const { FleetModel } = await import('../src/fleet_model.js');
  const { GoalTracker } = await import('../src/goal_pointer.js');
  const { SensorHistory } = await import('../src/sensor_history.js');
  const { CommandSender } = await import('../src/command_sender.js');
  const { sensorPanel } = await import('../src/sensor_panel.js');
  const { readFileSync } = await import('node:fs');
  const hello = JSON.parse(readFileSync(new URL('./fixtures/hello.json', import.meta.url), 'utf8'));
  const fleet = new FleetModel();
  const history = new SensorHistory();
  const sender = new CommandSender(/** @type {any} */ ({ send: () => null }), () => {});
  const router = new MessageRouter({ fleet, goals: new GoalTracker(), history, commands: sender });
  router.route(hello, 0);
  const sensor = (/** @type {number} */ t) =>
    router.route(
      { identifier: 'robot1/sensor', name: 'gas', value: 5, unit: 'ppm', warning: false, stamp: t / 1000 },
      t,
    );
  for (let t = 0; t <= 2000; t += 200) sensor(t);
  const panel = (/** @type {number} */ now) =>
    sensorPanel(fleet, 'robot1', history, { text: '', ok: true }, now, '', {
      freshness: router.freshness,
      linkStale: router.linkStale(true, now),
    });
  assert.equal(panel(2100).sensors.find((s) => s.name === 'gas')?.stale, null);
  assert.equal(router.linkStale(true, 2100), false);
  assert.equal(router.linkStale(true, 2000 + 3100), true, 'silence past the pings');
  assert.equal(router.linkStale(false, 2100), true, 'no link');
  assert.equal(panel(2000 + 3100).sensors.find((s) => s.name === 'gas')?.stale, '3 s ago');
  assert.deepEqual(router.route(hello, 9000).at(-1), {
    type: 'notify',
    text: 'Reconnected: showing the fleet as the relay sees it now',
    kind: 'info',
    toast: true,
  });
});

test('a sparkline spans its warning threshold, so noise far below it draws flat, and the line has a height', async () => {
  const { SensorHistory } = await import('../src/sensor_history.js');
  const h = new SensorHistory();
  [5, 3, 7, 4, 6].forEach((v, i) => h.add('robot1', 'gas', v, false, i * 200));
  const scaled = h.sparkline('robot1', 'gas', 1000, 100, 40, { above: 400 });
  const ys = scaled.points.map((p) => p[1]);
  assert.ok(Math.max(...ys) - Math.min(...ys) < 1, '±2 ppm under a 400 ppm threshold is flat');
  assert.equal(scaled.lines.length, 1);
  assert.ok(scaled.lines[0] > 0 && scaled.lines[0] < 10, 'the threshold near the top, inside the box');
  const bare = h.sparkline('robot1', 'gas', 1000, 100, 40);
  const spread = Math.max(...bare.points.map((p) => p[1])) - Math.min(...bare.points.map((p) => p[1]));
  assert.ok(spread > 30, 'without a threshold the noise fills the box (10 % of the level is less than 4 ppm)');
});
