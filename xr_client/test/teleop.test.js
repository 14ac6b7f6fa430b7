// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { keysToStick, shapeStick, TeleopLoop, TELEOP_PERIOD_MS } from '../src/teleop.js';

const limits = { linear: 0.6, angular: 1.8 };
/** @param {number} a @param {number} b */
const close = (a, b, eps = 1e-9) => assert.ok(Math.abs(a - b) < eps, `${a} != ${b}`);

test('forward/back is linear, left/right is angular, scaled to the limits at full deflection', () => {
  assert.deepEqual(shapeStick(0, -1, limits), { linear: 0.6, angular: 0 });
  assert.deepEqual(shapeStick(0, 1, limits), { linear: -0.6, angular: 0 });
  assert.deepEqual(shapeStick(-1, 0, limits), { linear: 0, angular: 1.8 }); // left = counter-clockwise
  assert.deepEqual(shapeStick(1, 0, limits), { linear: 0, angular: -1.8 });
});

test('a radial dead-zone, no jump at its edge, and an expo curve below full deflection', () => {
  assert.deepEqual(shapeStick(0.1, -0.1, limits), { linear: 0, angular: 0 });
  const edge = shapeStick(0, -0.151, limits);
  assert.ok(edge.linear > 0 && edge.linear < 0.01);
  // Half travel past the dead-zone: (1 - expo)·0.5 + expo·0.125 of the limit.
  const half = shapeStick(0, -(0.15 + 0.85 * 0.5), limits, { deadzone: 0.15, expo: 0.4 });
  close(half.linear, 0.6 * (0.6 * 0.5 + 0.4 * 0.125));
  // Never beyond the limits, even on a diagonal.
  const diag = shapeStick(1, -1, limits);
  assert.ok(diag.linear <= 0.6 && diag.angular >= -1.8);
});

test('commands at a fixed 20 Hz while held, one zero on release, silence after', () => {
  const loop = new TeleopLoop();
  loop.setRobot('robot2', limits, 0);
  /** @type {any[]} */
  const sent = [];
  sent.push(...loop.input('right', 0.3, 0, 1000));
  for (let t = 1000; t <= 2000; t += 1000 / 72) {
    sent.push(...loop.input('right', 0.3, 0, t));
    sent.push(...loop.tick(t));
  }
  assert.ok(sent.length >= 20 && sent.length <= 22, `sent ${sent.length} in one second`);
  assert.ok(sent.every((c) => c.robot === 'robot2' && c.linear === 0.3));
  const release = loop.input('right', 0, 0, 2010);
  assert.deepEqual(release, [{ robot: 'robot2', linear: 0, angular: 0 }]);
  assert.deepEqual(loop.tick(3000), []);
  assert.deepEqual(loop.input('right', 0, 0, 3010), []);
  assert.equal(TELEOP_PERIOD_MS, 50);
});

test('never two sources for one robot', () => {
  const loop = new TeleopLoop();
  loop.setRobot('robot1', limits, 0);
  assert.equal(loop.input('keyboard', 0.6, 0, 0).length, 1);
  assert.deepEqual(loop.input('gamepad', -0.6, 0, 10), []);
  assert.deepEqual(loop.tick(60), [{ robot: 'robot1', linear: 0.6, angular: 0 }]);
  // The holder releases: one zero; then the other source may drive.
  assert.deepEqual(loop.input('keyboard', 0, 0, 70), [{ robot: 'robot1', linear: 0, angular: 0 }]);
  assert.equal(loop.input('gamepad', -0.6, 0, 200)[0].linear, -0.6);
});

test('a stop (switch, menu, hidden tab, session end) sends one zero and needs the stick re-centred', () => {
  const loop = new TeleopLoop();
  loop.setRobot('robot1', limits, 0);
  loop.input('right', 0.5, 0.2, 0);
  assert.deepEqual(loop.stop(10), [{ robot: 'robot1', linear: 0, angular: 0 }]);
  assert.deepEqual(loop.stop(20), []);
  assert.deepEqual(loop.input('right', 0.5, 0.2, 100), []); // still held: ignored
  assert.deepEqual(loop.tick(200), []);
  loop.input('right', 0, 0, 300);
  assert.equal(loop.input('right', 0.5, 0.2, 400).length, 1);
  // Switching robot stops the old one first.
  assert.deepEqual(loop.setRobot('robot2', limits, 450), [{ robot: 'robot1', linear: 0, angular: 0 }]);
  // Nothing was driven: a stop sends nothing (a zero cmd_vel would cancel a navigating robot's goal).
  assert.deepEqual(loop.stop(500), []);
});

test('keys make a virtual stick', () => {
  assert.deepEqual(keysToStick(new Set(['KeyW'])), [0, -1]);
  assert.deepEqual(keysToStick(new Set(['ArrowDown', 'ArrowLeft'])), [-1, 1]);
  assert.deepEqual(keysToStick(new Set(['KeyA', 'KeyD'])), [0, 0]);
});
