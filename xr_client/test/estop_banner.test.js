// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { estopBanner } from '../src/estop_banner.js';

const FLEET = ['robot1', 'robot2', 'robot3'];

test('no latch, no banner; the whole fleet latched reads as one fleet-wide stop', () => {
  assert.equal(estopBanner([], FLEET, new Map(), 'c1', true), null);
  const by = new Map(FLEET.map((r) => [r, 'c1']));
  const banner = estopBanner(FLEET, FLEET, by, 'c1', true);
  assert.deepEqual(banner, {
    fleet: true,
    robots: FLEET,
    text: 'ALL ROBOTS E-STOPPED · by you',
    hint: 'stopped and held: nothing moves them until Reset E-STOP',
  });
});

test('one robot stopped names it and who stopped it; a viewer is told an operator resets it', () => {
  const banner = estopBanner(['robot2'], FLEET, new Map([['robot2', 'c7-ab']]), 'c1', false);
  assert.equal(banner?.fleet, false);
  assert.equal(banner?.text, 'E-STOPPED: robot2 · by c7-ab');
  assert.equal(banner?.hint, 'stopped and held until an operator resets it');
  // The presser by the name the relay gives (an account's, or the one they typed), never an id when one is known.
  const named = estopBanner(
    ['robot2'],
    FLEET,
    new Map([['robot2', 'c7-ab']]),
    'c1',
    false,
    new Map([['c7-ab', 'Ana']]),
  );
  assert.equal(named?.text, 'E-STOPPED: robot2 · by Ana');
});

test('robots stopped by different operators, or by whom nobody said (a reconnect), name no one', () => {
  assert.equal(
    estopBanner(
      ['robot1', 'robot2'],
      FLEET,
      new Map([
        ['robot1', 'c1'],
        ['robot2', 'c2'],
      ]),
      'c1',
      true,
    )?.text,
    'E-STOPPED: robot1, robot2',
  );
  assert.equal(estopBanner(['robot1'], FLEET, new Map(), 'c1', true)?.text, 'E-STOPPED: robot1');
});
