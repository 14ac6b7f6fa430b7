// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { paceAnimationFrames } from '../src/emulator_pace.js';

/** A window whose clock, timers and display frames (every 1000/60 ms) the test moves by hand. */
function fakeWindow() {
  let now = 0;
  let ids = 0;
  /** @type {Map<number, {at: number, fn: Function}>} */
  const timers = new Map();
  /** @type {Map<number, Function>} */
  const frames = new Map();
  const win = {
    performance: { now: () => now },
    setTimeout: (/** @type {Function} */ fn, /** @type {number} */ ms) => {
      timers.set(++ids, { at: now + ms, fn });
      return ids;
    },
    clearTimeout: (/** @type {number} */ id) => timers.delete(id),
    requestAnimationFrame: (/** @type {Function} */ fn) => {
      frames.set(++ids, fn);
      return ids;
    },
    cancelAnimationFrame: (/** @type {number} */ id) => frames.delete(id),
  };
  /** Run the clock to `until` ms: timers when due, display frames at 60 Hz. @param {number} until */
  function advance(until) {
    for (let t = now; t <= until; t += 1) {
      now = t;
      for (const [id, timer] of [...timers]) {
        if (timer.at <= now) {
          timers.delete(id);
          timer.fn();
        }
      }
      if (t % (1000 / 60) < 1) {
        const due = [...frames];
        frames.clear();
        for (const [, fn] of due) fn(now);
      }
    }
  }
  return { win: /** @type {any} */ (win), advance, pending: () => timers.size + frames.size };
}

test('an emulated headset that asks for every frame is called back at most N times a second', () => {
  const { win, advance } = fakeWindow();
  paceAnimationFrames(win, 5);
  /** @type {number[]} */
  const calls = [];
  const loop = (/** @type {number} */ time) => {
    calls.push(time);
    win.requestAnimationFrame(loop);
  };
  win.requestAnimationFrame(loop);
  advance(2000);
  // 5 a second: the first at once, then one every 200 ms (each on the display frame after its slot).
  assert.ok(calls.length >= 10 && calls.length <= 11, `${calls.length} calls in 2 s`);
  for (let i = 1; i < calls.length; i++) assert.ok(calls[i] - calls[i - 1] >= 199, `${calls[i] - calls[i - 1]} ms`);
});

test('a cancelled frame is never called, whether it waits for its slot or for the display', () => {
  const { win, advance, pending } = fakeWindow();
  paceAnimationFrames(win, 5);
  let called = 0;
  win.requestAnimationFrame(() => called++); // the first slot: at once, on the next display frame
  const waiting = win.requestAnimationFrame(() => called++); // the next slot, 200 ms on
  advance(20);
  assert.equal(called, 1);
  win.cancelAnimationFrame(waiting);
  advance(1000);
  assert.equal(called, 1);
  assert.equal(pending(), 0);
});
