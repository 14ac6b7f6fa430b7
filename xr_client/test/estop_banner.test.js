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
    question: 'Reset the E-STOP pressed by you on all robots? They can move again as soon as they are commanded.',
  });
});

test("a reset's question names whose E-STOP it lifts, on which robots, each presser apart", () => {
  const names = new Map([
    ['c7-ab', 'Ana'],
    ['c9-cd', 'Ben'],
  ]);
  const one = estopBanner(['robot2'], FLEET, new Map([['robot2', 'c7-ab']]), 'c1', true, names);
  assert.match(one?.question ?? '', /^Reset the E-STOP pressed by Ana on robot2\?/);
  const by = new Map([
    ['robot1', 'c7-ab'],
    ['robot2', 'c9-cd'],
    ['robot3', 'c7-ab'],
  ]);
  const several = estopBanner(FLEET, FLEET, by, 'c1', true, names);
  assert.match(several?.question ?? '', /^Reset the E-STOPs pressed by Ana on robot1, robot3; by Ben on robot2\?/);
  // Latched before this page connected: the relay did not say who, and the question says so rather than guess.
  const unknown = estopBanner(['robot3'], FLEET, new Map(), 'c1', true, names);
  assert.match(unknown?.question ?? '', /pressed by someone the relay did not name on robot3\?/);
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
