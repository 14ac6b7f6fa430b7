// @ts-check
/**
 * The desktop's schedule form, under the schedule list (view/findings_panel.js draws the list, with Edit and Remove
 * on each row and New schedule in its head, and places this form under it), closed until one of those opens it: a
 * name; what its runs start (targets picked from those the page knows, for a robot or the fleet, or a mission file);
 * the first run; the minutes between runs; launch windows (weekdays and hours of the relay's clock) and blackouts; a
 * priority; and what a run does when its robot is busy. It sends
 * `schedule/add`, or `schedule/update` with the fields changed; a removal is confirmed in the page first.
 *
 * Nothing is shown before the relay says so: an `ack` clears the form and the list is the relay's `schedules`
 * message; an `error` stays beside the form, its field marked. Operators only: a viewer's schedule commands are
 * `forbidden`, so a viewer sees the list alone. Behaviour is schedule_draft.js's; this is DOM only.
 */
import { may } from '../roles.js';
import { localTime, ScheduleEditor, WEEKDAYS } from '../schedule_draft.js';
import { missionWords } from '../schedule_list.js';
import { esc } from './html.js';

export class ScheduleForm {
  /** Whether this client may change schedules (an operator; a viewer sees the list only). */
  visible = false;
  /** What the form was last drawn with: the editor's version, and the targets and robots offered. */
  #drawn = '';

  /**
   * @param {import('../inspection_model.js').InspectionModel} model the schedules, targets and answers
   * @param {import('../command_sender.js').CommandSender} sender
   * @param {import('./confirm_dialog.js').ConfirmDialog} confirm asks before a removal
   * @param {() => number} [wall] seconds since the epoch (a new schedule's first run is a minute from now)
   */
  constructor(model, sender, confirm, wall = () => Date.now() / 1000) {
    this.model = model;
    this.sender = sender;
    this.confirm = confirm;
    this.wall = wall;
    this.editor = new ScheduleEditor(wall());
    /** The robots a run may be given to (the menu's, from `hello`). @type {string[]} */
    this.robots = [];
    this.element = document.createElement('form');
    this.element.className = 'schedule-form';
    this.element.noValidate = true; // the relay checks the rules and names the field; the page shows its answer
    this.element.setAttribute('aria-label', 'Make or change a schedule');
    this.element.addEventListener('submit', (event) => {
      event.preventDefault();
      this.#submit();
    });
    // What is typed goes into the draft at once: a redraw (a new target, an answer) never loses it.
    this.element.addEventListener('input', () => this.#read());
    this.element.addEventListener('change', () => this.#read());
    this.element.addEventListener('click', (event) => {
      const button = /** @type {HTMLElement} */ (event.target).closest('button[data-act]');
      if (button instanceof HTMLButtonElement && button.type === 'button') this.#act(button);
    });
  }

  /**
   * The relay's news and the operator's role: the answer to the command sent, if it came, and the form redrawn
   * when what it shows changed. @param {import('../menu_state.js').MenuState} menu
   */
  update(menu) {
    const { editor, model } = this;
    const pending = editor.pending;
    if (pending && !model.awaiting.has(pending.request) && !model.settled.has(pending.request)) editor.reset();
    editor.settle(model.settled, model.refusals, this.wall());
    editor.sync(model.schedules);
    this.visible = may(menu.role, 'inspect');
    this.robots = menu.robots.map((r) => r.name);
    this.#draw();
  }

  /**
   * Put the form where the panel's redraw left room for it, keeping the focus and the cursor of what was typed in.
   * @param {Element | null} slot
   */
  mount(slot) {
    if (!slot || !this.visible) return;
    const active = document.activeElement;
    const inside = active instanceof HTMLInputElement && this.element.contains(active) ? active : null;
    const [from, to] = inside && inside.type === 'text' ? [inside.selectionStart, inside.selectionEnd] : [null, null];
    slot.replaceWith(this.element);
    if (active instanceof HTMLElement && this.element.contains(active)) active.focus();
    if (inside && from !== null) inside.setSelectionRange(from, to);
  }

  /** Open the form for a new schedule (the list's New schedule). */
  start() {
    if (!this.visible) return;
    this.editor.start(this.wall());
    this.#draw();
  }

  /** Fill the form with a listed schedule to change it (its row's Edit). @param {string} name */
  edit(name) {
    const schedule = this.model.schedules.find((s) => s.schedule === name);
    if (!schedule || !this.visible) return;
    this.editor.edit(schedule);
    this.#draw();
    this.element.scrollIntoView({ block: 'nearest' });
  }

  /** Remove a schedule (its row's Remove), once the operator confirms it in the page. @param {string} name */
  async remove(name) {
    if (!this.visible) return;
    const yes = await this.confirm.ask(
      `Remove the schedule ${name}? Its runs stop; the missions it started stay in the record.`,
      'Remove',
    );
    if (!yes || this.editor.pending) return;
    const request = this.sender.scheduleRemove(name);
    if (request) this.model.await(String(request));
    this.editor.sent(request, 'remove', name);
    this.#draw();
  }

  #submit() {
    this.#read();
    const command = this.editor.submit();
    if (command) {
      const request = this.sender.schedule(command);
      if (request) this.model.await(String(request));
      this.editor.sent(request, 'change', command.schedule);
    }
    this.#draw();
  }

  /** A button of the form that is not its submit: add or drop a window or blackout, clear. @param {HTMLElement} b */
  #act(b) {
    const draft = this.editor.draft;
    const n = Number(b.dataset.n);
    if (b.dataset.act === 'add-window') draft.windows.push({ days: [...WEEKDAYS], first: '0', last: '24' });
    else if (b.dataset.act === 'drop-window') draft.windows.splice(n, 1);
    else if (b.dataset.act === 'add-blackout') {
      const from = this.wall() + 3600;
      draft.blackouts.push({ start: localTime(from), end: localTime(from + 3600) });
    } else if (b.dataset.act === 'drop-blackout') draft.blackouts.splice(n, 1);
    else if (b.dataset.act === 'cancel') this.editor.close(this.wall());
    this.#draw(true);
  }

  /** The inputs into the draft (the only place the form is read). */
  #read() {
    const form = this.element;
    const draft = this.editor.draft;
    /** @param {string} name */
    const value = (name) => /** @type {HTMLInputElement | null} */ (form.querySelector(`[name="${name}"]`))?.value;
    /** @param {string} name */
    const checked = (name) =>
      [...form.querySelectorAll(`input[name="${name}"]:checked`)].map((i) => /** @type {HTMLInputElement} */ (i).value);
    if (!this.editor.open) return;
    if (!this.editor.before) draft.name = value('schedule') ?? draft.name;
    draft.what = /** @type {any} */ (checked('what')[0] ?? draft.what);
    // Picked in order: those picked before keep their place, a new one goes last (a robot inspects them in order).
    const picked = new Set(checked('target'));
    draft.targets = [
      ...draft.targets.filter((t) => picked.has(t)),
      ...[...picked].filter((t) => !draft.targets.includes(t)),
    ];
    draft.robot = value('robot') ?? draft.robot;
    draft.file = value('file') ?? draft.file;
    draft.start = value('start') ?? draft.start;
    draft.repeat = value('repeat') ?? draft.repeat;
    draft.windows = draft.windows.map((w, n) => ({
      days: checked(`days-${n}`),
      first: value(`first-${n}`) ?? w.first,
      last: value(`last-${n}`) ?? w.last,
    }));
    draft.blackouts = draft.blackouts.map((b, n) => ({
      start: value(`from-${n}`) ?? b.start,
      end: value(`to-${n}`) ?? b.end,
    }));
    draft.priority = value('priority') ?? draft.priority;
    draft.onBusy = value('on_busy') === 'skip' ? 'skip' : 'wait';
  }

  /** Redraw when what the form shows changed (or `force`: rows added or dropped). @param {boolean} [force] */
  #draw(force = false) {
    const targets = [...this.model.targets.values()].map((t) => [t.id, t.name]);
    const key = JSON.stringify([this.editor.version, this.visible, this.robots, targets, this.editor.pending]);
    if (key === this.#drawn && !force) return;
    this.#drawn = key;
    // The field with the focus keeps it (a tick box by its value too: the targets' and the days' share a name).
    const active = document.activeElement;
    const field = active instanceof HTMLInputElement || active instanceof HTMLSelectElement ? active : null;
    const shared = field?.type === 'checkbox' || field?.type === 'radio';
    const value = field && shared ? `[value="${CSS.escape(field.value)}"]` : '';
    const focused = field && this.element.contains(field) ? `[name="${CSS.escape(field.name)}"]${value}` : null;
    this.element.hidden = !this.visible;
    this.element.classList.toggle('open', this.editor.open);
    // Closed, the form is nothing but a refused removal's error.
    const refused = this.editor.error ? `<p class="error" role="alert">${esc(this.editor.error)}</p>` : '';
    this.element.innerHTML = this.editor.open
      ? this.#html(new Map(/** @type {[string, string][]} */ (targets)))
      : refused;
    const error = this.editor.field;
    if (error) this.element.querySelector(`[data-field="${error}"]`)?.classList.add('invalid');
    if (focused) /** @type {HTMLElement | null} */ (this.element.querySelector(focused))?.focus();
  }

  /** @param {Map<string, string>} known the targets the page knows: id, name */
  #html(known) {
    const { draft, before, pending, error } = this.editor;
    const what = (/** @type {string} */ kind) => (draft.what === kind ? ' checked' : '');
    // Those the draft names first, in its order (a robot inspects them so), then the others the page knows.
    const ids = [...draft.targets, ...[...known.keys()].filter((t) => !draft.targets.includes(t))];
    const targets = ids
      .map((id) => {
        const on = draft.targets.includes(id) ? ' checked' : '';
        const label = known.has(id) ? (known.get(id) ?? id) : `${id} (not a target now)`;
        return `<label class="pick"><input type="checkbox" name="target" value="${esc(id)}"${on}>${esc(label)}</label>`;
      })
      .join('');
    const robots = ['', ...this.robots.filter((r) => r !== draft.robot), ...(draft.robot ? [draft.robot] : [])]
      .map((r) => {
        const words = r || 'the fleet (the nearest free robot each)';
        return `<option value="${esc(r)}"${r === draft.robot ? ' selected' : ''}>${esc(words)}</option>`;
      })
      .join('');
    const kept = draft.kept
      ? `<label><input type="radio" name="what" value="kept"${what('kept')}>as made: ` +
        `${esc(missionWords(draft.kept))}</label>`
      : '';
    const windows = draft.windows.map((w, n) => windowRow(w, n, draft.windows.length > 1)).join('');
    const blackouts = draft.blackouts.map(blackoutRow).join('');
    const busy = /** @type {const} */ ([
      ['wait', 'wait for it, until the run’s deadline'],
      ['skip', 'skip the run'],
    ])
      .map(([v, words]) => `<option value="${v}"${draft.onBusy === v ? ' selected' : ''}>${words}</option>`)
      .join('');
    const title = before ? `Change ${esc(before.schedule)}` : 'New schedule';
    const wait = pending ? ' disabled' : '';
    return (
      `<b>${title}</b>` +
      `<label data-field="schedule">Name <input type="text" name="schedule" maxlength="64" autocomplete="off" ` +
      `spellcheck="false" value="${esc(draft.name)}"${before ? ' readonly' : ''}></label>` +
      `<fieldset data-field="mission"><legend>Each run starts</legend>` +
      `<label><input type="radio" name="what" value="targets"${what('targets')}>these targets, in order</label>` +
      `<div class="picks">${targets || '<small>no targets yet</small>'}</div>` +
      `<label>by <select name="robot" aria-label="robot">${robots}</select></label>` +
      `<label><input type="radio" name="what" value="file"${what('file')}>the mission file ` +
      `<input type="text" name="file" maxlength="64" spellcheck="false" placeholder="demo" ` +
      `value="${esc(draft.file)}" aria-label="mission file"></label>${kept}</fieldset>` +
      `<label data-field="start">First run <input type="datetime-local" step="1" name="start" ` +
      `value="${esc(draft.start)}"></label>` +
      `<label data-field="repeat">Every <input type="number" name="repeat" min="1" step="any" ` +
      `value="${esc(draft.repeat)}"> minutes</label>` +
      `<fieldset data-field="windows"><legend>Launch windows (days, hours of the relay’s clock)</legend>` +
      `${windows}<button type="button" data-act="add-window">Add window</button></fieldset>` +
      `<fieldset data-field="blackouts"><legend>Blackouts (no run starts)</legend>` +
      `${blackouts}<button type="button" data-act="add-blackout">Add blackout</button></fieldset>` +
      `<label data-field="priority">Priority <input type="number" name="priority" step="1" min="-1000" max="1000" ` +
      `value="${esc(draft.priority)}"> <small>higher first, when runs are due together</small></label>` +
      `<label data-field="on_busy">Robot busy, E-stopped or offline: <select name="on_busy">${busy}</select></label>` +
      `<p class="error" role="alert"${error ? '' : ' hidden'}>${esc(error)}</p>` +
      `<p class="buttons"><button type="submit" data-act="save"${wait}>` +
      `${before ? 'Save changes' : 'Add schedule'}</button>` +
      '<button type="button" data-act="cancel">Cancel</button>' +
      `${pending ? '<small>sent; waiting for the relay</small>' : ''}</p>`
    );
  }
}

/**
 * One launch window: its weekdays and hours.
 * @param {import('../schedule_draft.js').WindowRow} w @param {number} n @param {boolean} droppable
 */
function windowRow(w, n, droppable) {
  const days = WEEKDAYS.map(
    (d) =>
      `<label class="day"><input type="checkbox" name="days-${n}" value="${d}"` +
      `${w.days.includes(d) ? ' checked' : ''}>${d}</label>`,
  ).join('');
  const drop = droppable
    ? `<button type="button" data-act="drop-window" data-n="${n}" aria-label="drop window ${n + 1}">×</button>`
    : '';
  return (
    `<div class="row window">${days}<span class="hours">from <input type="number" name="first-${n}" min="0" ` +
    `max="24" step="1" value="${esc(w.first)}" aria-label="window ${n + 1} first hour"> to ` +
    `<input type="number" name="last-${n}" min="0" max="24" step="1" value="${esc(w.last)}" ` +
    `aria-label="window ${n + 1} last hour"> h</span>${drop}</div>`
  );
}

/**
 * One blackout: the local times it runs from and to.
 * @param {import('../schedule_draft.js').BlackoutRow} b @param {number} n
 */
function blackoutRow(b, n) {
  return (
    `<div class="row">from <input type="datetime-local" step="1" name="from-${n}" value="${esc(b.start)}" ` +
    `aria-label="blackout ${n + 1} from"> to <input type="datetime-local" step="1" name="to-${n}" ` +
    `value="${esc(b.end)}" aria-label="blackout ${n + 1} to"> ` +
    `<button type="button" data-act="drop-blackout" data-n="${n}" aria-label="drop blackout ${n + 1}">×</button></div>`
  );
}
