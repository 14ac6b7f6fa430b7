// @ts-check
/**
 * A replay's timeline in the page's header (playback_timeline.js): play or pause, a slider to seek, the speed. Shown
 * only while the robots are a replay. While the operator drags the slider, the relay's reports do not move it; the
 * seek goes when it is let go. dispose() removes its listeners.
 */
import { PLAYBACK_RATES, playbackCommand, timeline } from '../playback_timeline.js';

export class PlaybackBar {
  /**
   * @param {(message: ReturnType<typeof playbackCommand>) => void} send a playback command to the relay
   * @param {Document} [doc]
   */
  constructor(send, doc = document) {
    const el = (/** @type {string} */ id) => /** @type {HTMLElement} */ (doc.getElementById(id));
    this.bar = el('playback-bar');
    this.toggle = /** @type {HTMLButtonElement} */ (el('playback-toggle'));
    this.seek = /** @type {HTMLInputElement} */ (el('playback-seek'));
    this.rate = /** @type {HTMLSelectElement} */ (el('playback-rate'));
    this.time = el('playback-time');
    this.dragging = false;
    /** @type {'pause' | 'resume'} */
    this.action = 'pause';
    for (const rate of PLAYBACK_RATES) this.rate.add(new Option(`${rate}×`, String(rate), rate === 1, rate === 1));
    /** @type {[EventTarget, string, (e: Event) => void][]} */
    this.listeners = [
      [this.toggle, 'click', () => send(playbackCommand(this.action))],
      [this.seek, 'input', () => (this.dragging = true)],
      [
        this.seek,
        'change',
        () => {
          this.dragging = false;
          send(playbackCommand('seek', Number(this.seek.value)));
        },
      ],
      [this.rate, 'change', () => send(playbackCommand('rate', Number(this.rate.value)))],
    ];
    for (const [target, type, fn] of this.listeners) target.addEventListener(type, fn);
  }

  /**
   * The replay's latest `playback` (null: live robots, no bar).
   * @param {import('../protocol.js').PlaybackMessage | null} playback
   */
  show(playback) {
    const shown = timeline(playback);
    this.bar.hidden = shown === null;
    if (!shown) return;
    this.action = shown.toggle;
    this.toggle.textContent = shown.toggleText;
    this.seek.max = String(shown.duration);
    this.seek.step = '0.1';
    if (!this.dragging) this.seek.value = String(shown.position);
    this.time.textContent = shown.text;
    if (!PLAYBACK_RATES.includes(shown.rate)) this.rate.add(new Option(`${shown.rate}×`, String(shown.rate)));
    this.rate.value = String(shown.rate);
  }

  dispose() {
    for (const [target, type, fn] of this.listeners) target.removeEventListener(type, fn);
    this.listeners = [];
  }
}
