// @ts-check
/**
 * Sound and haptics on the page: every 100 ms (a timer, off the render path) the fleet's state goes through
 * cue_rules.js, and the relay's events bring cues of their own (`cue`: a lease lost); cues play as earcons at their
 * robots' places (sound.js) and pulse the controllers in VR. The AudioContext is made on the operator's first gesture
 * (browsers allow sound only after one). The listener follows the camera (the headset in VR). The header's Sound
 * button, the menu's Mute (VR too) and M mute; the header's slider and the menu's Volume − and + (VR too) set the
 * volume; G switches the Geiger-like ticking of the selected robot's hazard reading (its first sensor with a warning
 * level).
 */
import * as THREE from 'three';
import { CueRules, hapticFor } from '../cue_rules.js';
import { Soundscape } from './sound.js';
import { typingIn } from './typing.js';

const POLL_MS = 100;

/**
 * @typedef {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
 *   goals: import('../goal_pointer.js').GoalTracker, camera: THREE.Camera,
 *   robotViews: Map<string, import('./robot_view.js').RobotView>, inputSources: () => Iterable<XRInputSource>}}
 *   SoundHost
 * @typedef {import('../cue_rules.js').Cue} Cue
 */

export class SoundControl {
  /** @param {SoundHost} host */
  constructor(host) {
    this.host = host;
    this.rules = new CueRules();
    /** @type {Soundscape | null} */
    this.scape = null;
    this.muted = false;
    this.disposed = false;
    this.volume = 0.6;
    this.geiger = false;
    /** Cues played and pulses sent, by kind (the state snapshot shows them). @type {Record<string, number>} */
    this.played = {};
    this.pulses = 0;
    this.ticks = 0;
    this.button = /** @type {HTMLButtonElement | null} */ (document.getElementById('sound-toggle'));
    this.slider = /** @type {HTMLInputElement | null} */ (document.getElementById('sound-volume'));
    const start = () => this.#start();
    this.onGesture = start;
    window.addEventListener('pointerdown', start, { capture: true });
    window.addEventListener('keydown', start, { capture: true });
    this.onKey = (/** @type {KeyboardEvent} */ e) => {
      if (typingIn(e.target) || e.repeat) return;
      if (e.key === 'm' || e.key === 'M') this.setMuted(!this.muted);
      if (e.key === 'g' || e.key === 'G') this.setGeiger(!this.geiger);
    };
    window.addEventListener('keydown', this.onKey);
    this.button?.addEventListener('click', () => this.setMuted(!this.muted));
    this.slider?.addEventListener('input', () => this.setVolume(Number(this.slider?.value ?? 60) / 100));
    this.timer = setInterval(() => this.poll(performance.now()), POLL_MS);
    this.#paint();
  }

  /** The first gesture: sound may start now. */
  #start() {
    if (this.disposed) return;
    window.removeEventListener('pointerdown', this.onGesture, { capture: true });
    window.removeEventListener('keydown', this.onGesture, { capture: true });
    if (this.scape || typeof AudioContext === 'undefined') return;
    this.scape = new Soundscape(new AudioContext());
    this.scape.setVolume(this.volume);
    this.scape.setMuted(this.muted);
  }

  /** @param {boolean} muted */
  setMuted(muted) {
    this.muted = muted;
    this.host.menu.options.muted = muted; // the menu's Mute shows it, in VR too
    this.scape?.setMuted(muted);
    this.#paint();
  }

  /** @param {number} volume 0..1 */
  setVolume(volume) {
    this.volume = volume;
    this.host.menu.options.volume = volume; // the menu's Volume buttons step from it, in VR too
    this.scape?.setVolume(volume);
    this.#paint();
  }

  /** @param {boolean} on */
  setGeiger(on) {
    this.geiger = on;
    this.host.menu.options.ticks = on; // the menu's Hazard ticks shows it, in VR too
    if (!on) this.rules.stopTicks();
    this.#paint();
  }

  #paint() {
    if (this.button) this.button.textContent = this.muted ? 'Sound: off' : `Sound${this.geiger ? ' + ticks' : ''}`;
    if (this.slider) this.slider.value = String(Math.round(this.volume * 100));
  }

  /** @param {string} name @returns {{x: number, y: number, z: number} | null} */
  #place(name) {
    const view = this.host.robotViews.get(name);
    return view ? view.group.getWorldPosition(new THREE.Vector3()) : null;
  }

  /** One look at the fleet: cues to play and pulse, and the hazard tick. @param {number} now ms */
  poll(now) {
    const { fleet, menu, goals } = this.host;
    const options = menu.options;
    if (options.muted !== this.muted) this.setMuted(options.muted); // the menu's Mute (VR, the desktop menu)
    if (options.volume !== this.volume) this.setVolume(options.volume); // its Volume − and +
    if (options.ticks !== this.geiger) this.setGeiger(options.ticks); // its Hazard ticks
    /** @type {import('../cue_rules.js').RobotView[]} */
    const robots = [];
    for (const [name, entry] of fleet.robots) {
      const warnings = [...entry.sensors.values()].filter((r) => r.warning).map((r) => r.name);
      robots.push({
        name,
        x: entry.pose?.x ?? 0,
        y: entry.pose?.y ?? 0,
        warnings,
        goal: goals.goals.get(name)?.state ?? null,
        latched: menu.latched.includes(name),
      });
    }
    const cues = this.rules.update(robots, now);
    if (this.scape) this.#listen(this.scape);
    for (const cue of cues) this.#sound(cue);
    const selected = menu.selected ? fleet.robot(menu.selected) : null;
    if (this.geiger && selected && menu.selected) {
      const sensor = selected.description.sensors.find((s) => s.warn_above !== null);
      const reading = sensor ? selected.sensors.get(sensor.name) : undefined;
      if (sensor && reading && sensor.warn_above !== null && this.rules.tick(reading.value, sensor.warn_above, now)) {
        this.ticks++;
        this.scape?.play('tick', this.#place(menu.selected));
      }
    }
  }

  /** A cue told by an event (control_news.js: a lease lost): heard and felt at once. @param {Cue} cue */
  cue(cue) {
    if (this.scape) this.#listen(this.scape);
    this.#sound(cue);
  }

  /** The listener where the camera (the headset in VR) is, looking where it looks. @param {Soundscape} scape */
  #listen(scape) {
    const camera = this.host.camera;
    const at = camera.getWorldPosition(new THREE.Vector3());
    const forward = camera.getWorldDirection(new THREE.Vector3());
    const up = new THREE.Vector3(0, 1, 0).applyQuaternion(camera.getWorldQuaternion(new THREE.Quaternion()));
    scape.listen(at, forward, up);
  }

  /** Play a cue at its robot and pulse the controllers for it. @param {Cue} cue */
  #sound(cue) {
    const { fleet, menu } = this.host;
    this.played[cue.kind] = (this.played[cue.kind] ?? 0) + 1;
    this.scape?.play(cue.kind, cue.robot ? this.#place(cue.robot) : null);
    const selected = menu.selected ? fleet.robot(menu.selected) : null;
    const near =
      selected?.pose && menu.selected ? { name: menu.selected, x: selected.pose.x, y: selected.pose.y } : null;
    const robot = cue.robot ? fleet.robot(cue.robot) : null;
    const pulse = hapticFor(cue, { selected: near, at: robot?.pose ?? null });
    if (pulse) this.#pulse(pulse);
  }

  /** @param {{intensity: number, ms: number, pulses: number}} pulse */
  #pulse(pulse) {
    for (const source of this.host.inputSources()) {
      const gamepad = /** @type {any} */ (source.gamepad);
      const actuator = gamepad?.hapticActuators?.[0] ?? gamepad?.vibrationActuator;
      if (!actuator) continue;
      this.pulses++;
      // Each pulse schedules the next from when it was sent: timers queued at once fire back to back after a long
      // frame (a software-rendered one takes 100-300 ms), and two pulses 0.4 ms apart are felt as one buzz.
      const send = (/** @type {number} */ left) => {
        if (left <= 0 || this.disposed) return;
        if (typeof actuator.pulse === 'function') actuator.pulse(pulse.intensity, pulse.ms);
        else
          actuator.playEffect?.('dual-rumble', {
            duration: pulse.ms,
            strongMagnitude: pulse.intensity,
            weakMagnitude: pulse.intensity,
          });
        if (left > 1) setTimeout(() => send(left - 1), pulse.ms + 60);
      };
      send(pulse.pulses);
    }
  }

  /** What the state snapshot shows (`window.__xrRelay.state.sound`). */
  state() {
    return {
      started: this.scape !== null,
      muted: this.muted,
      volume: this.volume,
      geiger: this.geiger,
      played: { ...this.played },
      pulses: this.pulses,
      ticks: this.ticks,
    };
  }

  dispose() {
    clearInterval(this.timer);
    window.removeEventListener('keydown', this.onKey);
    this.disposed = true;
    const ctx = /** @type {AudioContext | undefined} */ (this.scape?.ctx);
    void ctx?.close();
  }
}
