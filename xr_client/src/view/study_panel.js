// @ts-check
/**
 * The desktop page's study panel (docs/study.md): drawn from the study model (study_model.js) whenever the relay's
 * `study` message changes it, and every quarter second while a task's time runs. It shows who takes part and lets an
 * operator join them, the task's instruction with Start, the time left, the SUS (ten items, 1-5, radio buttons) and
 * the raw NASA-TLX (six sliders 0-100), and a probe's question with its answers, all by mouse. What the participant
 * chooses goes to the relay through the page's connection; the panel changes nothing but the answers being given.
 */
import { esc } from './html.js';
import { SUS_ITEMS, TLX_SCALES, clockText, probeQuestion } from '../study_model.js';

/** How often the time left is redrawn while a task runs (ms). */
const TICK_MS = 250;

export class StudyPanel {
  /**
   * @param {HTMLElement | null} root (null: no page)
   * @param {import('../study_model.js').StudyModel} model
   * @param {{send(message: Record<string, unknown>, withId?: boolean): string | null}} link the page's connection
   * @param {(text: string) => void} onNotSent
   */
  constructor(root, model, link, onNotSent) {
    this.root = root;
    this.model = model;
    this.link = link;
    this.onNotSent = onNotSent;
    /** Why the answers cannot be sent yet, shown under them. */
    this.missing = '';
    /** @type {ReturnType<typeof setInterval> | null} */
    this.timer = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    if (!root) return;
    const onClick = (/** @type {MouseEvent} */ e) => this.#click(/** @type {HTMLElement} */ (e.target));
    const onInput = (/** @type {Event} */ e) => this.#input(/** @type {HTMLInputElement} */ (e.target));
    root.addEventListener('click', onClick);
    root.addEventListener('input', onInput);
    root.addEventListener('change', onInput);
    this.unlisten.push(
      () => root.removeEventListener('click', onClick),
      () => root.removeEventListener('input', onInput),
      () => root.removeEventListener('change', onInput),
    );
  }

  /** The model changed (a `study` message): draw it again. */
  update() {
    this.missing = '';
    this.#draw();
    const running = this.model.message?.phase === 'task';
    if (running && this.timer === null) this.timer = setInterval(() => this.#tick(), TICK_MS);
    if (!running && this.timer !== null) {
      clearInterval(this.timer);
      this.timer = null;
    }
  }

  #tick() {
    const left = this.model.timeLeft(performance.now());
    const shown = this.root?.querySelector('.time-left');
    if (shown && left !== null) shown.textContent = clockText(left);
  }

  /** @param {HTMLElement} target */
  #click(target) {
    const button = /** @type {HTMLElement | null} */ (target.closest('button[data-study]'));
    if (!button) return;
    const model = this.model;
    const action = button.dataset.study;
    /** @type {import('../study_model.js').StudyCommand | null} */
    let command = null;
    if (action === 'join') command = model.join();
    else if (action === 'start') command = model.start();
    else if (action === 'probe') command = model.answerProbe(button.dataset.choice ?? '');
    else if (action === 'answer') {
      const answer = model.answer();
      if ('missing' in answer) {
        this.missing = answer.missing;
        const said = this.root?.querySelector('.missing');
        if (said) said.textContent = this.missing;
        return;
      }
      command = answer.command;
    }
    if (command && this.link.send(/** @type {Record<string, unknown>} */ (command)) === null)
      this.onNotSent(`not connected: ${command.identifier} not sent`);
  }

  /**
   * A press of the VR menu's question buttons (study_model.js `menuQuestion`): the answer set, or the command sent,
   * or why not said; the page's panel drawn again with the answers so far. @param {string} id
   */
  pressMenu(id) {
    const result = this.model.pressMenu(id);
    if ('missing' in result) this.onNotSent(result.missing);
    else if ('command' in result && this.link.send(/** @type {Record<string, unknown>} */ (result.command)) === null)
      this.onNotSent(`not connected: ${result.command.identifier} not sent`);
    this.#draw();
  }

  /** @param {HTMLInputElement} input */
  #input(input) {
    const model = this.model;
    const said = this.root?.querySelector('.missing');
    if (said) said.textContent = this.missing = '';
    if (input.name === 'participant') model.choose(input.value);
    else if (input.name?.startsWith('sus-')) model.setSus(Number(input.name.slice(4)), Number(input.value));
    else if (input.name?.startsWith('tlx-')) {
      model.setTlx(Number(input.name.slice(4)), Number(input.value));
      const shown = input.parentElement?.querySelector('output');
      if (shown) shown.textContent = String(model.tlx[Number(input.name.slice(4))]);
    }
  }

  #draw() {
    const root = this.root;
    if (!root) return;
    const m = this.model.message;
    root.hidden = m === null;
    if (m === null) return;
    const about = [m.participant, m.condition, m.total ? `${m.done} of ${m.total} tasks done` : null]
      .filter((part) => part)
      .map((part) => esc(String(part)))
      .join(' · ');
    const head = `<div class="head"><b>Study ${esc(m.study)}</b><small>${about}</small></div>`;
    // The questionnaires take the middle of the view; the rest leaves the twin in sight.
    root.classList.toggle('asking', m.phase === 'questions');
    root.innerHTML = head + this.#body(m);
  }

  /** @param {import('../protocol.js').StudyMessage} m @returns {string} */
  #body(m) {
    const model = this.model;
    switch (m.phase) {
      case 'waiting':
      case 'done': {
        const options = m.participants
          .map((p) => `<option${p === model.participant ? ' selected' : ''}>${esc(p)}</option>`)
          .join('');
        const done = m.phase === 'done' ? `<p>${esc(m.participant ?? '')} has done every task. Thank you.</p>` : '';
        return `${done}<label>Participant <select name="participant">${options}</select></label>
          <button type="button" data-study="join">Join</button>`;
      }
      case 'ready': {
        const settings = Object.entries(m.settings).map(([k, v]) => `${k} ${v}`);
        const under = `<p class="condition">Condition ${esc(m.condition ?? '')}${
          settings.length ? `: ${esc(settings.join(', '))}` : ''
        }</p>`;
        return `${under}<p class="instruction">${esc(m.instruction ?? '')}</p>
          <p>Time: ${clockText(m.time_limit ?? 0)}</p><button type="button" data-study="start">Start</button>`;
      }
      case 'task':
        return `<p class="instruction">${esc(m.instruction ?? '')}</p>
          <p>Time left: <b class="time-left">${clockText(model.timeLeft(performance.now()) ?? 0)}</b></p>`;
      case 'probe': {
        const probe = m.probe;
        if (!probe) return '';
        const choices = probe.choices
          .map((c) => `<button type="button" data-study="probe" data-choice="${esc(c)}">${esc(c)}</button>`)
          .join('');
        return `<p class="question">${esc(probeQuestion(probe))}</p><div class="choices">${choices}</div>`;
      }
      case 'questions':
        return (
          (m.questionnaire === 'sus' ? this.#sus() : this.#tlx()) +
          `<p class="missing">${esc(this.missing)}</p><button type="button" data-study="answer">Send answers</button>`
        );
    }
    return '';
  }

  #sus() {
    const rows = SUS_ITEMS.map((item, i) => {
      const radios = [1, 2, 3, 4, 5]
        .map((v) => {
          const checked = this.model.sus[i] === v ? ' checked' : '';
          return `<label><input type="radio" name="sus-${i}" value="${v}"${checked}>${v}</label>`;
        })
        .join('');
      return `<li><span>${esc(item)}</span><span class="scale" data-item="${i + 1}">${radios}</span></li>`;
    }).join('');
    return `<p>About the station under this condition: 1 strongly disagree … 5 strongly agree.</p>
      <ol class="sus">${rows}</ol>`;
  }

  #tlx() {
    const rows = TLX_SCALES.map((s, i) => {
      const value = this.model.tlx[i];
      return `<li><span>${esc(s.question)}</span><span class="scale"><small>${esc(s.low)}</small>
        <input type="range" name="tlx-${i}" min="0" max="100" step="5" value="${value}" aria-label="${esc(s.name)}">
        <small>${esc(s.high)}</small><output>${value}</output></span></li>`;
    }).join('');
    return `<p>About the task you just did.</p><ol class="tlx">${rows}</ol>`;
  }

  dispose() {
    if (this.timer !== null) clearInterval(this.timer);
    this.timer = null;
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}
