// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { arcPoints, floorCrossing } from '../src/arc.js';
import { ERROR_VISIBLE_MS, GoalPointer, GoalTracker } from '../src/goal_pointer.js';

/** @param {number} a @param {number} b */
const close = (a, b, eps = 1e-9) => assert.ok(Math.abs(a - b) < eps, `${a} != ${b}`);

test('press sets the position at the hit point, dragging sets the heading, release sends', () => {
  const p = new GoalPointer();
  assert.equal(p.press(), false); // nothing under the pointer
  p.aim({ x: 3, y: 6 });
  assert.equal(p.state, 'aiming');
  assert.equal(p.press(), true);
  p.aim({ x: 3.1, y: 6.1 }); // a short drag sets no heading
  assert.equal(p.yaw, null);
  p.aim({ x: 3, y: 7 }); // drag north: heading +90 degrees
  close(/** @type {number} */ (p.yaw), Math.PI / 2);
  assert.deepEqual(p.marker, { x: 3, y: 6, yaw: Math.PI / 2 });
  const goal = p.release();
  assert.deepEqual(goal, { x: 3, y: 6, yaw: Math.PI / 2 });
  assert.equal(p.release(), null);
});

test('a press without a drag sends no heading; leaving the floor keeps the anchor', () => {
  const p = new GoalPointer();
  p.aim({ x: 1, y: 2 });
  p.press();
  p.aim(null);
  assert.deepEqual(p.release(), { x: 1, y: 2, yaw: null });
});

test('the arc is a parabola that ends exactly on the floor', () => {
  const { points, hit } = arcPoints([0, 1.2, 0], [0, 0, -1], { speed: 5, gravity: 9.8 });
  assert.ok(hit);
  close(hit[1], 0);
  const t = Math.sqrt((2 * 1.2) / 9.8);
  close(hit[2], -5 * t);
  close(floorCrossing(1.2, 0, 9.8), t);
  assert.deepEqual(points.at(-1), hit);
  // Aimed at the sky with few points: no hit.
  assert.equal(arcPoints([0, 1, 0], [0, 1, 0], { maxPoints: 5 }).hit, null);
});

test('a goal stays until the relay reports it reached or cancelled; errors show, then fade', () => {
  const goals = new GoalTracker();
  goals.sent('robot2', { x: 3, y: 6, yaw: null }, 'r1', 0);
  assert.equal(goals.display('robot2', 1)?.state, 'pending');
  goals.status('robot2', null, 2); // a status from before the goal: ignored while pending
  assert.equal(goals.display('robot2', 3)?.state, 'pending');
  goals.acked('r1');
  goals.status('robot2', { x: 3, y: 6, yaw: null }, 10);
  assert.equal(goals.display('robot2', 11)?.state, 'active');
  goals.status('robot2', null, 20);
  assert.equal(goals.display('robot2', 21), null);
  goals.sent('robot1', { x: 40, y: 2, yaw: null }, 'r2', 100);
  assert.equal(goals.failed('r2', 'out_of_bounds', 'outside the map', 110), true);
  assert.equal(goals.display('robot1', 200)?.error?.code, 'out_of_bounds');
  assert.equal(goals.display('robot1', 110 + ERROR_VISIBLE_MS + 1), null);
});
