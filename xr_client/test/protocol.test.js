// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { cameraIdentifier, parseIdentifier, robotIdentifier, ERROR_CODES } from '../src/protocol.js';

test('robot-scoped identifiers split at the first slash; the kind keeps the rest', () => {
  assert.deepEqual(parseIdentifier('robot1/pose'), { robot: 'robot1', kind: 'pose' });
  assert.deepEqual(parseIdentifier('robot1/camera/front'), { robot: 'robot1', kind: 'camera/front' });
  assert.deepEqual(parseIdentifier(cameraIdentifier('r2', 'rear')), { robot: 'r2', kind: 'camera/rear' });
  assert.equal(robotIdentifier('robot3', 'lease'), 'robot3/lease');
});

test('global identifiers have no robot, even those with a slash', () => {
  for (const identifier of ['hello', 'ack', 'error', 'estop', 'backend', 'playback', 'playback/seek']) {
    assert.deepEqual(parseIdentifier(identifier), { robot: null, kind: identifier });
  }
  assert.deepEqual(parseIdentifier('/pose'), { robot: null, kind: '/pose' });
});

test("error codes are the relay's", () => {
  assert.equal(ERROR_CODES.LEASED, 'leased');
  assert.ok(Object.isFrozen(ERROR_CODES));
});
