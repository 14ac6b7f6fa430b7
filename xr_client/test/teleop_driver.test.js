// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { CommandSender } from '../src/command_sender.js';
import { TeleopLoop } from '../src/teleop.js';
import { CONFIRM_MS, TeleopDriver } from '../src/teleop_driver.js';

const limits = { linear: 0.6, angular: 1.8 };
const robot2 = { name: 'robot2', limits };

/** A connection that records, in one log, what the page sends and what it tells the worker to hold. @param {boolean} worker */
function station(worker) {
  /** @type {any[]} */
  const log = [];
  const link = new EventTarget();
  const connection = {
    link,
    /** @param {any} command @param {number} epoch */
    hold: (command, epoch) => (log.push(['hold', command && command.linear, epoch]), worker && command !== null),
    /** @param {any} message */
    send: (message) => (log.push(['send', message.linear]), ''),
  };
  const sender = new CommandSender(
    connection,
    () => {},
    () => 0,
  );
  /** @type {string[]} */
  const notices = [];
  const driver = new TeleopDriver(new TeleopLoop(), sender, connection, (text) => notices.push(text));
  return { log, link, driver, sender, notices };
}

test('with the worker: the page sends the first command and the zero, the worker the repeats; null before the zero', () => {
  const { log, driver } = station(true);
  driver.stick('keyboard', 0, -1, robot2, 0);
  assert.deepEqual(log, [
    ['hold', 0.6, 0],
    ['send', 0.6],
  ]);
  log.length = 0;
  for (let t = 10; t < 1000; t += 10) driver.tick(t);
  assert.ok(
    log.every(([kind]) => kind === 'hold'),
    'no repeats from the page',
  );
  // Confirmed while the page runs, at least every CONFIRM_MS.
  assert.ok(log.length >= 1000 / CONFIRM_MS - 1 && log.length <= 1000 / CONFIRM_MS + 1, `${log.length} confirmations`);
  log.length = 0;
  driver.stick('keyboard', 0, 0, robot2, 1000);
  assert.deepEqual(log.slice(-2), [
    ['hold', null, 0],
    ['send', 0],
  ]);
});

test('without a worker the page sends every command at 20 Hz, as before', () => {
  const { log, driver } = station(false);
  driver.stick('keyboard', 0, -1, robot2, 0);
  for (let t = 10; t <= 1000; t += 10) driver.tick(t);
  assert.equal(log.filter(([kind]) => kind === 'send').length, 21);
});

test('a stop that sends no zero (E-STOP, the robot taken over) still stops the worker', () => {
  const { log, driver } = station(true);
  driver.stick('xr-right', 0, -1, robot2, 0);
  log.length = 0;
  driver.stop(20, true);
  assert.deepEqual(log, [['hold', null, 0]]);
});

test('a switch of robot: the worker stops repeating before the old robot gets its zero', () => {
  const { log, driver } = station(true);
  driver.stick('xr-right', 0, -1, robot2, 0);
  log.length = 0;
  driver.setRobot('robot1', limits, 30);
  assert.deepEqual(log, [
    ['hold', null, 0],
    ['send', 0],
  ]);
});

test('the worker stopped the robot: the page stops its loop, says so, and drives again only from the centre', () => {
  const { log, link, driver, notices, sender } = station(true);
  driver.stick('keyboard', 0, -1, robot2, 0);
  link.dispatchEvent(new CustomEvent('sent', { detail: { zero: false } }));
  link.dispatchEvent(new CustomEvent('sent', { detail: { zero: true } }));
  assert.deepEqual({ cmdVel: sender.counts.cmdVel, zeros: sender.counts.zeros }, { cmdVel: 3, zeros: 1 });
  log.length = 0;
  link.dispatchEvent(new CustomEvent('expired', { detail: { identifier: 'robot2/cmd_vel', silent: 1200, epoch: 1 } }));
  assert.deepEqual(log, [['hold', null, 1]], 'no second zero from the page; the worker is told nothing is held');
  assert.equal(driver.epoch, 1);
  assert.match(notices[0], /did not answer for 1\.2 s/);
  log.length = 0;
  driver.stick('keyboard', 0, -1, robot2, 2000); // still held: ignored until centred
  assert.deepEqual(log, []);
  driver.stick('keyboard', 0, 0, robot2, 2100);
  driver.stick('keyboard', 0, -1, robot2, 2200);
  assert.deepEqual(log, [
    ['hold', 0.6, 1],
    ['send', 0.6],
  ]);
});
