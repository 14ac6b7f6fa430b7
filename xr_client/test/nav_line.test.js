// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { navLine, formatEta, OUTCOME_MS } from '../src/nav_line.js';
import { MessageRouter } from '../src/message_router.js';
import { FleetModel } from '../src/fleet_model.js';
import { GoalTracker } from '../src/goal_pointer.js';
import { SensorHistory } from '../src/sensor_history.js';
import { CommandSender } from '../src/command_sender.js';

const HELLO = JSON.parse(readFileSync(new URL('./fixtures/hello.json', import.meta.url), 'utf8'));
const GOAL = { x: 9, y: 6, yaw: null };

/** A `<robot>/nav` as the relay sends it (docs/protocol.md), with `fields` changed. @param {Record<string, any>} fields */
function nav(fields) {
  return /** @type {import('../src/protocol.js').NavMessage} */ ({
    identifier: 'robot1/nav',
    outcome: 'started',
    goal: GOAL,
    message: '',
    error_code: null,
    feedback: null,
    confirmed: null,
    ...fields,
  });
}

const FEEDBACK = { distance_remaining: 3.25, eta: 7.5, recoveries: 1, navigation_time: 12.3 };

test("the label says Nav2's feedback while the goal runs, then how it ended, for a while", () => {
  assert.equal(navLine(null, 'idle', 0), '');
  assert.equal(navLine({ message: nav({}), at: 0 }, 'navigating', 10), '', 'no feedback yet: nothing to add');
  const running = { message: nav({ feedback: FEEDBACK }), at: 0 };
  assert.equal(navLine(running, 'navigating', 10), '3.3 m · 8 s left · 1 recovery');
  assert.equal(
    navLine({ message: nav({ feedback: { ...FEEDBACK, recoveries: 0, eta: 95 } }), at: 0 }, 'navigating', 10),
    '3.3 m · 1 min 35 s left',
  );
  assert.equal(navLine(running, 'idle', 10), '', 'feedback of a goal the robot no longer follows is not news');
  const failed = {
    message: nav({ outcome: 'failed', error_code: 208, message: 'Nav2 aborted the goal: no valid path' }),
    at: 1000,
  };
  assert.equal(navLine(failed, 'idle', 1000), 'aborted (Nav2 error 208)');
  assert.equal(navLine(failed, 'idle', 1000 + OUTCOME_MS + 1), '', 'an outcome goes after a while');
  assert.equal(navLine({ message: nav({ outcome: 'reached' }), at: 0 }, 'idle', 5), 'goal reached');
  assert.equal(navLine({ message: nav({ outcome: 'cancelled' }), at: 0 }, 'idle', 5), 'cancelled');
  assert.equal(
    navLine({ message: nav({ outcome: 'cancelled', confirmed: true }), at: 0 }, 'idle', 5),
    'cancelled · Nav2 confirmed',
  );
  assert.equal(
    navLine({ message: nav({ outcome: 'cancelled', confirmed: false }), at: 0 }, 'idle', 5),
    'cancelled · Nav2 did not confirm',
  );
  assert.equal(formatEta(-1), '?');
});

test("feedback and Nav2's answers reach the label; a cancel Nav2 did not confirm is told as an error", () => {
  const fleet = new FleetModel();
  const commands = new CommandSender({ send: () => 'r1' }, () => {});
  const router = new MessageRouter({ fleet, goals: new GoalTracker(), history: new SensorHistory(), commands });
  router.route(HELLO, 0);
  router.route({ ...HELLO.state.robot1.status, mode: 'navigating', goal: GOAL }, 1);
  assert.deepEqual(router.route(nav({ feedback: FEEDBACK }), 2), [], 'feedback is no notice');
  assert.equal(navLine(fleet.robot('robot1')?.nav, 'navigating', 3), '3.3 m · 8 s left · 1 recovery');
  // A confirmation of a goal given up earlier does not replace the feedback of the goal followed now.
  assert.deepEqual(
    router.route(nav({ outcome: 'cancelled', confirmed: true, goal: { x: 1, y: 1, yaw: null } }), 4),
    [],
  );
  assert.equal(fleet.robot('robot1')?.nav?.message.outcome, 'started');
  // Given up: cancelled at once (a notice, as before), then Nav2's answer on the label.
  router.route({ ...HELLO.state.robot1.status, mode: 'idle', goal: null }, 5);
  const cancelled = router.route(nav({ outcome: 'cancelled', message: 'emergency stop' }), 6);
  assert.equal(/** @type {any} */ (cancelled[0]).text, "robot1's goal (9.0, 6.0) cancelled: emergency stop");
  assert.deepEqual(
    router.route(nav({ outcome: 'cancelled', confirmed: true, message: 'Nav2 is cancelling 1 goal' }), 7),
    [],
  );
  assert.equal(navLine(fleet.robot('robot1')?.nav, 'idle', 8), 'cancelled · Nav2 confirmed');
  const unanswered = router.route(
    nav({ outcome: 'cancelled', confirmed: false, message: 'Nav2 did not answer the cancel within 1 s' }),
    9,
  );
  assert.deepEqual(unanswered, [
    {
      type: 'nav',
      robot: 'robot1',
      text: 'robot1: Nav2 did not answer the cancel within 1 s',
      kind: 'error',
      mine: false,
    },
  ]);
  assert.equal(navLine(fleet.robot('robot1')?.nav, 'idle', 10), 'cancelled · Nav2 did not confirm');
});
