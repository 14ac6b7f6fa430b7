// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PLAYBACK_RATES, clock, playbackCommand, timeline } from '../src/playback_timeline.js';

/** @param {Partial<import('../src/protocol.js').PlaybackMessage>} fields */
function playback(fields) {
  return {
    identifier: /** @type {'playback'} */ ('playback'),
    position: 12.5,
    duration: 75.25,
    rate: 1,
    paused: false,
    loop: false,
    ...fields,
  };
}

test('the bar shows where a replay is and offers the other of play and pause', () => {
  assert.equal(timeline(null), null, 'live robots: no bar');
  const playing = timeline(playback({}));
  assert.deepEqual(playing, {
    playing: true,
    toggle: 'pause',
    toggleText: 'Pause',
    position: 12.5,
    duration: 75.25,
    rate: 1,
    text: '0:12.5 / 1:15.3',
  });
  assert.equal(timeline(playback({ paused: true }))?.toggle, 'resume');
  assert.equal(clock(0), '0:00.0');
  assert.equal(clock(61.04), '1:01.0');
});

test("each control sends the relay's playback command", () => {
  assert.deepEqual(playbackCommand('pause'), { identifier: 'playback/pause' });
  assert.deepEqual(playbackCommand('resume'), { identifier: 'playback/resume' });
  assert.deepEqual(playbackCommand('seek', 33.333), { identifier: 'playback/seek', t: 33.3 });
  assert.deepEqual(playbackCommand('seek', -2), { identifier: 'playback/seek', t: 0 });
  assert.deepEqual(playbackCommand('rate', 4), { identifier: 'playback/rate', rate: 4 });
  assert.ok(
    PLAYBACK_RATES.every((r) => r >= 0.05 && r <= 20),
    'within what the relay takes',
  );
});
