// @ts-check
/**
 * The station's sounds, synthesised (no audio files): short earcons, each placed at its robot with an HRTF
 * PannerNode so that a warning is heard from where the robot is, and the hazard ticks. The graph is built on any
 * BaseAudioContext, so a test renders it offline (OfflineAudioContext) and checks where it was panned
 * (tests/e2e/test_sound.py). Which sound when: cue_rules.js; the page's wiring: sound_control.js.
 *
 * Each earcon has its own shape, told apart without looking: a warning is two high alternating tones, a goal
 * accepted a rising pair, a refusal a falling buzz, a lease lost three short blips, an estop a low pulsing horn.
 */

/**
 * @typedef {import('../cue_rules.js').CueKind | 'tick'} SoundKind
 * @typedef {{x: number, y: number, z: number}} Point a point in the scene (metres, three.js world axes)
 */

/** Tones of each earcon: [start s, duration s, frequency Hz, end frequency Hz, wave, peak gain]. */
const TONES = /** @type {Record<SoundKind, [number, number, number, number, OscillatorType, number][]>} */ ({
  warning: [
    [0, 0.12, 880, 880, 'square', 0.25],
    [0.14, 0.12, 660, 660, 'square', 0.25],
    [0.28, 0.12, 880, 880, 'square', 0.25],
  ],
  goal_accepted: [
    [0, 0.09, 523, 523, 'sine', 0.4],
    [0.1, 0.14, 784, 784, 'sine', 0.4],
  ],
  goal_refused: [[0, 0.25, 330, 200, 'sawtooth', 0.25]],
  lease_lost: [
    [0, 0.06, 440, 440, 'triangle', 0.4],
    [0.1, 0.06, 440, 440, 'triangle', 0.4],
    [0.2, 0.06, 440, 440, 'triangle', 0.4],
  ],
  estop: [
    [0, 0.22, 220, 180, 'square', 0.35],
    [0.3, 0.22, 220, 180, 'square', 0.35],
  ],
  tick: [[0, 0.004, 2400, 2400, 'square', 0.3]],
});

export class Soundscape {
  /** @param {BaseAudioContext} ctx */
  constructor(ctx) {
    this.ctx = ctx;
    this.master = ctx.createGain();
    this.master.connect(ctx.destination);
    this.volume = 0.6;
    this.muted = false;
    this.#applyGain();
  }

  /** @param {number} volume 0..1 */
  setVolume(volume) {
    this.volume = Math.min(1, Math.max(0, volume));
    this.#applyGain();
  }

  /** @param {boolean} muted */
  setMuted(muted) {
    this.muted = muted;
    this.#applyGain();
  }

  #applyGain() {
    this.master.gain.value = this.muted ? 0 : this.volume;
  }

  /**
   * Where the operator's head is and where it looks (scene axes). @param {Point} at @param {Point} forward
   * @param {Point} up
   */
  listen(at, forward, up) {
    const l = this.ctx.listener;
    if (l.positionX) {
      l.positionX.value = at.x;
      l.positionY.value = at.y;
      l.positionZ.value = at.z;
      l.forwardX.value = forward.x;
      l.forwardY.value = forward.y;
      l.forwardZ.value = forward.z;
      l.upX.value = up.x;
      l.upY.value = up.y;
      l.upZ.value = up.z;
    } else {
      l.setPosition(at.x, at.y, at.z);
      l.setOrientation(forward.x, forward.y, forward.z, up.x, up.y, up.z);
    }
  }

  /**
   * Play an earcon, from ``at`` (a robot's place: HRTF-panned) or from everywhere (null: a fleet-wide estop).
   * @param {SoundKind} kind @param {Point | null} at @param {number} [when] context time (s)
   */
  play(kind, at, when = this.ctx.currentTime) {
    /** @type {AudioNode} */
    let out = this.master;
    if (at) {
      const panner = this.ctx.createPanner();
      panner.panningModel = 'HRTF';
      panner.distanceModel = 'inverse';
      panner.refDistance = 2;
      panner.rolloffFactor = 0.6;
      if (panner.positionX) {
        panner.positionX.value = at.x;
        panner.positionY.value = at.y;
        panner.positionZ.value = at.z;
      } else {
        panner.setPosition(at.x, at.y, at.z);
      }
      panner.connect(this.master);
      out = panner;
    }
    for (const [start, duration, f0, f1, wave, peak] of TONES[kind]) {
      const osc = this.ctx.createOscillator();
      const env = this.ctx.createGain();
      osc.type = wave;
      const t0 = when + start;
      osc.frequency.setValueAtTime(f0, t0);
      if (f1 !== f0) osc.frequency.linearRampToValueAtTime(f1, t0 + duration);
      // A short attack and release: no clicks at the edges.
      env.gain.setValueAtTime(0, t0);
      env.gain.linearRampToValueAtTime(peak, t0 + Math.min(0.01, duration / 3));
      env.gain.setValueAtTime(peak, t0 + Math.max(duration - 0.02, (duration * 2) / 3));
      env.gain.linearRampToValueAtTime(0, t0 + duration);
      osc.connect(env).connect(out);
      osc.start(t0);
      osc.stop(t0 + duration + 0.01);
    }
  }
}
