// @ts-check
/**
 * A replay's timeline on the page (`playback`, docs/protocol.md: a bag or a recorded session): what the bar shows
 * and the command each of its controls sends. No DOM: test/playback_timeline.test.js drives it; view/playback_bar.js
 * draws it.
 */

/** The speeds the bar offers (the relay takes 0.05 to 20). */
export const PLAYBACK_RATES = Object.freeze([0.25, 0.5, 1, 2, 4, 8]);

/**
 * @typedef {{playing: boolean, toggle: 'pause' | 'resume', toggleText: string, position: number,
 *   duration: number, rate: number, text: string}} Timeline
 * @typedef {Omit<import('./protocol.js').PlaybackCommand, 'id'>
 *   | Omit<import('./protocol.js').PlaybackSeekCommand, 'id'>
 *   | Omit<import('./protocol.js').PlaybackRateCommand, 'id'>} PlaybackRequest a playback command, without its id
 */

/**
 * What the bar shows for a `playback` message; null when the robots are not a replay (the bar hides).
 * @param {import('./protocol.js').PlaybackMessage | null} playback @returns {Timeline | null}
 */
export function timeline(playback) {
  if (!playback) return null;
  const playing = !playback.paused;
  return {
    playing,
    toggle: playing ? 'pause' : 'resume',
    toggleText: playing ? 'Pause' : 'Play',
    position: playback.position,
    duration: playback.duration,
    rate: playback.rate,
    text: `${clock(playback.position)} / ${clock(playback.duration)}`,
  };
}

/** Seconds as m:ss.s. @param {number} seconds */
export function clock(seconds) {
  const s = Math.max(0, seconds);
  const minutes = Math.floor(s / 60);
  return `${minutes}:${(s - minutes * 60).toFixed(1).padStart(4, '0')}`;
}

/**
 * The command of one control (without its id): pause, resume, seek to `value` s (clamped to 0..duration by the
 * relay), or speed `value`.
 * @param {'pause' | 'resume' | 'seek' | 'rate'} action @param {number} [value]
 * @returns {PlaybackRequest}
 */
export function playbackCommand(action, value = 0) {
  if (action === 'seek') return { identifier: 'playback/seek', t: Math.max(0, Math.round(value * 10) / 10) };
  if (action === 'rate') return { identifier: 'playback/rate', rate: value };
  return { identifier: `playback/${action}` };
}
