// @ts-check
/**
 * Voice on the page: push-to-talk (the header's Talk button held, the V key held, a controller's thumbstick
 * press held in VR) into the Web Speech API's recogniser; each phrase parsed by voice_grammar.js and carried out
 * through the same actions as the menu and keys, so leases, the estop latch and the relay's refusals apply.
 * What was heard is always shown (a caption above the message line; in VR, the HUD's message line), with
 * what it did, the confirmation it waits for, or why it was refused. Where the browser has no speech recognition
 * (Firefox, Quest Browser today), the button says so and is disabled.
 */
import { CONFIRM_MS, VoiceConfirm, describe, parse } from '../voice_grammar.js';
import { onePhrase, recognizerClass } from './dictation.js';
import { typingIn } from './typing.js';

/**
 * @typedef {import('./dictation.js').Recognition} Recognition
 * @typedef {{actions: import('../app.js').OperatorActions, menu: import('../menu_state.js').MenuState,
 *   fleet: import('../fleet_model.js').FleetModel, targets: () => {name: string, x: number, y: number}[],
 *   activeMission: (robot: string) => boolean, presenting: () => boolean, toast: (text: string) => void,
 *   groups: () => import('../robot_groups.js').RobotGroup[]}} VoiceHost
 */

export class VoiceControl {
  /** @param {VoiceHost} host */
  constructor(host) {
    this.host = host;
    this.confirm = new VoiceConfirm();
    this.Recognizer = recognizerClass();
    this.available = this.Recognizer !== null;
    /** @type {Recognition | null} */
    this.recognition = null;
    this.listening = false;
    /** The last phrase heard and what became of it (the caption). */
    this.heard = '';
    this.result = '';
    /**
     * Commands carried out, by kind (tests and the curious read them in the state snapshot).
     * @type {Record<string, number>}
     */
    this.done = {};
    this.button = /** @type {HTMLButtonElement | null} */ (document.getElementById('voice-talk'));
    this.caption = document.getElementById('voice-caption');
    this.#bind();
  }

  #bind() {
    const button = this.button;
    if (button) {
      if (!this.available) {
        button.disabled = true;
        button.textContent = 'Voice: not in this browser';
        button.title = 'This browser has no speech recognition (Web Speech API): use the menu, keys or controllers';
      } else {
        button.addEventListener('pointerdown', (e) => {
          e.preventDefault();
          this.talk(true);
        });
        for (const type of ['pointerup', 'pointerleave', 'pointercancel'])
          button.addEventListener(type, () => this.talk(false));
      }
    }
    window.addEventListener('keydown', (e) => {
      if ((e.key === 'v' || e.key === 'V') && !e.repeat && !typingIn(e.target)) this.talk(true);
    });
    window.addEventListener('keydown', (e) => {
      // Enter confirms a spoken command that waits (the desktop's pinch); typing in a field is not a confirmation.
      if (e.key === 'Enter' && !e.repeat && !typingIn(e.target) && this.confirmByGesture('Enter')) e.preventDefault();
    });
    window.addEventListener('keyup', (e) => {
      if (e.key === 'v' || e.key === 'V') this.talk(false);
    });
  }

  /**
   * Push-to-talk pressed (true) or released (false): the phrase said in between is recognised. @param {boolean} down
   */
  talk(down) {
    if (!down) {
      if (this.listening) this.recognition?.stop(); // the recogniser delivers the phrase, then ends
      return;
    }
    if (!this.available || this.listening || !this.Recognizer) {
      if (!this.available && down) this.#show('', 'voice: this browser has no speech recognition');
      return;
    }
    const recognition = onePhrase(
      this.Recognizer,
      (text) => this.hear(text),
      (error) => this.#show('', `voice: ${error}`),
      () => {
        this.listening = false;
        this.#paintButton();
      },
    );
    this.recognition = recognition;
    this.listening = true;
    this.#paintButton();
    try {
      recognition.start();
    } catch (error) {
      this.listening = false;
      this.#show('', `voice: ${/** @type {Error} */ (error).message}`);
    }
  }

  /** A phrase heard (the recogniser's final transcript). @param {string} transcript */
  hear(transcript) {
    const { fleet, menu } = this.host;
    const vocab = {
      robots: [...fleet.robots.keys()],
      rooms: fleet.rooms,
      targets: this.host.targets(),
      selected: menu.selected,
      groups: this.host.groups(),
    };
    const parsed = parse(transcript, vocab);
    for (const effect of this.confirm.hear(parsed, performance.now())) this.#effect(effect, parsed.heard);
  }

  /** @param {import('../voice_grammar.js').VoiceEffect} effect @param {string} heard */
  #effect(effect, heard) {
    if (effect.type === 'say') this.#show(heard, effect.text);
    else if (effect.type === 'ask') {
      const gesture = this.host.presenting() ? 'pinch or pull the trigger on nothing' : 'press Enter';
      this.#show(heard, `${describe(effect.command)}? say "confirm" or ${gesture} ("cancel" drops it)`);
      // The question must not outstay its answer: a confirmation after CONFIRM_MS does nothing, so say it lapsed.
      setTimeout(() => this.#lapse(heard), effect.until - performance.now() + 20);
    } else this.#show(heard, this.#run(effect.command));
  }

  /**
   * A pinch, a trigger or Enter while a spoken motion command waits for its "confirm": carried out, and said so;
   * false (nothing done) when none waits, so that the gesture does what it otherwise would.
   * @param {string} how what confirmed it, for the caption
   */
  confirmByGesture(how) {
    const now = performance.now();
    this.confirm.expire(now);
    if (!this.confirm.pending) return false;
    for (const effect of this.confirm.confirm(now)) {
      if (effect.type === 'run') this.#show(this.heard, `${this.#run(effect.command)} (confirmed: ${how})`);
    }
    return true;
  }

  /** A spoken command that waited for its "confirm" past CONFIRM_MS: dropped, and said so. @param {string} heard */
  #lapse(heard) {
    const lapsed = this.confirm.expire(performance.now());
    if (lapsed) this.#show(heard, `not confirmed within ${CONFIRM_MS / 1000} s: ${describe(lapsed)} dropped`);
  }

  /**
   * Carry a command out through the host's actions; returns what it did.
   * @param {import('../voice_grammar.js').VoiceCommand} c
   */
  #run(c) {
    const { actions, menu } = this.host;
    this.done[c.kind] = (this.done[c.kind] ?? 0) + 1;
    switch (c.kind) {
      case 'select':
        actions.selectRobot(c.robot);
        return `selected ${c.robot}`;
      case 'goto':
        actions.goalTo(c.robot, { x: c.place.x, y: c.place.y, yaw: null });
        return `${c.robot}: goal sent to ${c.place.title} (${c.place.x}, ${c.place.y})`;
      case 'stop':
        actions.apply([{ type: 'estop', robot: c.robot }]);
        return `emergency stop of ${c.robot}`;
      case 'stop_all':
        actions.apply([{ type: 'estop' }]);
        return 'emergency stop of every robot';
      case 'stop_group':
        actions.apply(c.robots.map((robot) => ({ type: /** @type {const} */ ('estop'), robot })));
        return `emergency stop of ${c.group}: ${c.robots.join(', ')}`;
      case 'snapshot':
        if (!c.robot) return 'snapshot: select a robot first ("robot one")';
        if (menu.selected !== c.robot) actions.selectRobot(c.robot);
        actions.apply([{ type: 'snapshot', robot: c.robot }]);
        return `snapshot of ${c.robot} asked`;
      case 'mission': {
        if (c.action === 'start') {
          actions.apply([{ type: 'mission', action: 'all', robot: menu.selected }]);
          return `mission over every target started for ${menu.selected ?? 'the fleet'}`;
        }
        const robots = menu.selected
          ? [menu.selected]
          : [...this.host.fleet.robots.keys()].filter((r) => this.host.activeMission(r));
        for (const robot of robots) actions.apply([{ type: 'mission', action: c.action, robot }]);
        return robots.length
          ? `${c.action} mission of ${robots.join(', ')}`
          : `${c.action} mission: no mission is running`;
      }
      case 'teleport':
        actions.selectRobot(c.robot);
        if (menu.mode !== 'pov') actions.pressMenu('mode:pov');
        return `riding along with ${c.robot} (Robot POV)`;
      case 'view':
        actions.pressMenu(`mode:${c.view}`);
        return c.view === 'pov' ? 'Robot POV' : 'free roam';
      default:
        return describe(c);
    }
  }

  /** @param {string} heard @param {string} result */
  #show(heard, result) {
    this.heard = heard;
    this.result = result;
    const text = heard ? `heard "${heard}": ${result}` : result;
    if (this.caption) {
      this.caption.textContent = text;
      this.caption.hidden = false;
    }
    if (this.host.presenting()) this.host.toast(text); // the page's caption is not seen in the headset: the HUD's toast
  }

  #paintButton() {
    if (!this.button || !this.available) return;
    this.button.textContent = this.listening ? 'Listening…' : 'Talk (hold V)';
    this.button.classList.toggle('active', this.listening);
  }

  /** What the state snapshot shows (`window.__xrRelay.state.voice`). */
  state() {
    const pending = this.confirm.pending;
    return {
      available: this.available,
      listening: this.listening,
      heard: this.heard,
      result: this.result,
      pending: pending ? describe(pending.command) : null,
      done: { ...this.done },
      button: this.button ? { text: this.button.textContent, disabled: this.button.disabled } : null,
    };
  }
}
