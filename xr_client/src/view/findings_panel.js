// @ts-check
/**
 * The alerts to acknowledge on the desktop (a count badge, each with its Acknowledge button; an alert another operator
 * acknowledged leaves the list), then the findings: a list with a status filter, and the selected finding's image
 * with its region, readings, the trend of its reading over the last rounds (a sparkline) and note. The operator
 * sets its status (a false alarm with a note saying why), and marks a region: a click on the image asks the relay to
 * segment around that pixel (GrabCut), the outline comes back drawn over the image, and Accept keeps it (Redo: click
 * again). Behaviour is the inspection review's (shared with the VR finding card); this is DOM only.
 */
import { STATUS_COLOURS } from '../change_colour.js';
import { changeColour } from '../change_colour.js';
import { FINDING_STATUSES, MAX_NOTE, nextName } from '../inspection_review.js';
import { NoteEditor } from './note_editor.js';
import { groupTitle } from '../robot_groups.js';
import { afterClip, WIPE_START, wipeAt, wipeLabels } from '../before_after.js';
import { reportLinks } from '../report_links.js';
import { scheduleRows } from '../schedule_list.js';
import { SPARK_BOX, labelY, polyline, sparkline } from '../sparkline.js';
import { statusWords } from '../wording.js';
import { esc } from './html.js';

export class FindingsPanel {
  /** @type {import('../protocol.js').FindingStatus | ''} */
  filter = '';
  /** The before/after slider's position (0-100): how much of the after image shows, from the left. */
  wipe = WIPE_START;
  /** The markup last put on the page. */
  html = '';
  /** The selected robot (a mission for it alone), or null (for the fleet). @type {string | null} */
  robot = null;
  /**
   * The group of robots chosen in the menu (its robots alone get the targets), or null.
   * @type {import('../robot_groups.js').RobotGroup | null}
   */
  group = null;
  /** The "since last round" switch turned (InspectionUi redraws pins, panel and menu). @type {(on: boolean) => void} */
  onSince = (on) => this.model.setSinceLastRound(on);

  /**
   * @param {HTMLElement} root
   * @param {import('../inspection_model.js').InspectionModel} model
   * @param {import('../inspection_review.js').InspectionReview} review what is open, picked and proposed
   * @param {(commands: import('../inspection_review.js').ReviewCommand[]) => void} run sends the review's commands
   * @param {string | null} token the operator token, for the capture images
   * @param {import('./target_dialog.js').TargetDialog} names names a new target in the page
   * @param {import('./schedule_form.js').ScheduleForm | null} [schedules] makes and changes schedules, under their list
   */
  constructor(root, model, review, run, token, names, schedules = null) {
    this.root = root;
    this.names = names;
    this.schedules = schedules;
    this.model = model;
    this.review = review;
    this.run = run;
    this.token = token;
    this.note = new NoteEditor();
    root.addEventListener('click', (event) =>
      this.#click(/** @type {HTMLElement} */ (event.target), /** @type {MouseEvent} */ (event)),
    );
    // The outline is in the image's pixels: its overlay takes the image's size once it is known.
    root.addEventListener(
      'load',
      (event) => {
        const img = event.target;
        if (!(img instanceof HTMLImageElement)) return;
        const overlay = img.nextElementSibling; // none for the before image: its sibling is the after one
        if (overlay instanceof SVGElement)
          overlay.setAttribute('viewBox', `0 0 ${img.naturalWidth} ${img.naturalHeight}`);
      },
      true,
    );
    // The slider moves the wipe in place: a render per step would reload the images.
    root.addEventListener('input', (event) => {
      if (event.target instanceof HTMLTextAreaElement && event.target.dataset.findingNote !== undefined) {
        const f = review.selected ? model.findings.get(review.selected) : null;
        if (f) this.note.typed(root, f, event.target.value);
        return;
      }
      const slider = event.target;
      if (!(slider instanceof HTMLInputElement) || slider.dataset.wipe === undefined) return;
      this.wipe = wipeAt(slider.value);
      this.#clip();
    });
    root.addEventListener('change', (event) => {
      if (event.target instanceof HTMLInputElement && event.target.dataset.since !== undefined) {
        this.onSince(event.target.checked);
        return;
      }
      // The status filter alone: the false alarm's note is read when sent, the schedule form reads its own.
      if (!(event.target instanceof HTMLSelectElement) || event.target.closest('.schedule-form')) return;
      this.filter = /** @type {any} */ (event.target.value);
      this.render();
    });
  }

  render() {
    const findings = this.model.visible({ status: this.filter || null });
    this.root.hidden =
      this.model.findings.size === 0 &&
      this.model.targets.size === 0 &&
      this.model.alerts.size === 0 &&
      this.model.schedules.length === 0 &&
      !this.schedules?.visible;
    const selected = this.review.selected;
    const options = ['', ...FINDING_STATUSES]
      .map((s) => `<option value="${s}"${s === this.filter ? ' selected' : ''}>${s ? statusWords(s) : 'all'}</option>`)
      .join('');
    const items = findings
      .map(
        (f) =>
          `<li data-finding="${esc(f.id)}" class="${f.id === selected ? 'active' : ''}">` +
          `<span class="dot" data-status="${esc(f.status)}" data-colour="${changeColour(f).colour}"></span>` +
          `${esc(f.target ?? f.robot)} · ${esc(f.robot)} · ${esc(statusWords(f.status))}` +
          `<br><small>${esc(firstWords(f.note))}</small></li>`,
      )
      .join('');
    // The report and work orders of the mission the selected (else the newest) finding came from, and a range.
    const about = (selected ? this.model.findings.get(selected) : null) ?? findings[0] ?? null;
    const links = reportLinks(about?.mission, this.token)
      .map((l) => `<a href="${esc(l.href)}" title="${esc(l.title)}" target="_blank" rel="noopener">${esc(l.text)}</a>`)
      .join('');
    // A redraw (any finding or alert that arrives) must not lose a false alarm's note being typed.
    const typing = /** @type {HTMLInputElement | null} */ (this.root.querySelector('input[data-note]'));
    const note = typing?.value ?? '';
    const focused = typing !== null && typing === document.activeElement;
    const writing = /** @type {HTMLTextAreaElement | null} */ (this.root.querySelector('textarea[data-finding-note]'));
    const caret = writing !== null && writing === document.activeElement ? writing.selectionStart : null;
    const targets = targetList(this.model.targets.values(), this.review.picked, this.robot, this.group);
    const html =
      `${alertList(this.model)}${scheduleList(this.model.schedules, this.schedules?.visible ?? false)}${targets}` +
      `<div class="head"><b>Findings (${this.model.findings.size})</b>` +
      `<span class="links">${links}</span><select aria-label="filter">${options}</select></div>` +
      `${sinceSwitch(this.model.sinceLastRound)}<ol>${items}</ol>${this.#older()}${this.#detail()}`;
    // Most updates (a target's progress, a mission's step) change nothing shown here: the page is left as it is, so
    // the images are not reloaded, a slider being dragged is not taken from under the mouse and nothing flickers.
    if (html === this.html) return;
    this.html = html;
    this.root.innerHTML = html;
    const input = /** @type {HTMLInputElement | null} */ (this.root.querySelector('input[data-note]'));
    if (input && note) input.value = note;
    if (input && focused) input.focus();
    const area = /** @type {HTMLTextAreaElement | null} */ (this.root.querySelector('textarea[data-finding-note]'));
    if (area && caret !== null) {
      area.focus();
      area.setSelectionRange(caret, caret);
    }
    // Colours through CSSOM: the relay's Content-Security-Policy blocks style attributes in markup (relay/headers.py).
    for (const dot of this.root.querySelectorAll('.dot[data-status]')) {
      const span = /** @type {HTMLElement} */ (dot);
      span.style.background =
        span.dataset.colour ?? STATUS_COLOURS[/** @type {keyof STATUS_COLOURS} */ (span.dataset.status)] ?? '';
    }
    this.schedules?.mount(this.root.querySelector('.schedule-form-slot'));
    this.#clip();
  }

  /** Older findings from the relay's database, a page at a time, until the oldest is here. */
  #older() {
    const history = this.model.history;
    if (this.model.findings.size === 0 || history === 'all') return '';
    const asked = history === 'asked';
    return `<p><button type="button" data-older="1"${asked ? ' disabled' : ''}>Older findings</button></p>`;
  }

  #detail() {
    const review = this.review;
    const f = review.selected ? this.model.findings.get(review.selected) : null;
    if (!f) return '';
    const region = review.outline(this.model);
    const src = f.image ? `${f.image}${this.token ? `?token=${encodeURIComponent(this.token)}` : ''}` : '';
    const outline = region
      ? `<polygon points="${region.map((p) => p.join(',')).join(' ')}" class="${review.proposal ? 'proposal' : ''}"/>`
      : '';
    const after =
      `<img src="${esc(src)}" alt="capture of ${esc(f.target ?? f.robot)}" ` +
      `data-capture="${esc(f.capture)}"><svg viewBox="0 0 1 1" preserveAspectRatio="none">${outline}</svg>`;
    const picture = !src
      ? '<p>no image</p>'
      : f.before
        ? beforeAfter(f, after, this.wipe, this.token, this.model.findings.values())
        : `<div class="capture">${after}</div>`;
    const readings = Object.entries(f.readings)
      .map(([k, v]) => `${esc(k)} ${v.toFixed(1)}`)
      .join(' · ');
    const buttons = FINDING_STATUSES.filter((s) => s !== 'false_alarm')
      .map((s) => {
        const active = s === f.status ? ' class="active"' : '';
        return `<button type="button" data-status="${s}"${active}>${statusWords(s)}</button>`;
      })
      .join('');
    const marked = f.status === 'false_alarm' ? ' class="active"' : '';
    const falseAlarm =
      `<input type="text" data-note data-space="text" maxlength="${MAX_NOTE}" aria-label="why it is a false alarm" ` +
      'placeholder="why it is a false alarm (a shadow, a passer-by)">' +
      `<button type="button" data-false-alarm${marked}>False alarm</button>`;
    const mark = 'click the image to mark a region; shift-click: a new target there';
    const regionButtons = review.proposal
      ? '<button type="button" data-region="accept">Accept region</button>' +
        '<button type="button" data-region="redo">Redo</button>'
      : `<small>${review.pending ? review.hint() : mark}</small>`;
    return (
      `<section class="finding">${picture}${this.note.html(f)}<p><small>${readings}</small></p>${trendFigure(f)}` +
      `<p>${buttons}</p><p class="false-alarm">${falseAlarm}</p><p>${regionButtons}</p></section>`
    );
  }

  /** The after image's share of the wipe (through CSSOM, as the dots' colours). */
  #clip() {
    const after = /** @type {HTMLElement | null} */ (this.root.querySelector('.wipe .after'));
    if (after) after.style.clipPath = afterClip(this.wipe);
  }

  /** @param {HTMLElement} target @param {MouseEvent} event */
  #click(target, event) {
    const review = this.review;
    const item = target.closest('[data-finding]');
    const pick = target.closest('[data-target]');
    if (target.dataset.ack) this.run([{ type: 'alert_ack', alert: target.dataset.ack }]);
    else if (target.dataset.scheduleNew !== undefined) this.schedules?.start();
    else if (target.dataset.scheduleEdit) this.schedules?.edit(target.dataset.scheduleEdit);
    else if (target.dataset.scheduleRemove) this.schedules?.remove(target.dataset.scheduleRemove);
    else if (pick) review.togglePick(/** @type {string} */ (pick.getAttribute('data-target')));
    else if (target.dataset.mission === 'start')
      this.run(review.startPicked(this.group ? null : this.robot, this.group?.robots ?? null));
    else if (target.dataset.older) this.run([{ type: 'findings_page', before: this.model.oldest() }]);
    else if (item) review.select(item.getAttribute('data-finding'));
    else if (target.dataset.status) this.run(review.setStatus(/** @type {any} */ (target.dataset.status)));
    else if (target.dataset.falseAlarm !== undefined) {
      const input = /** @type {HTMLInputElement | null} */ (this.root.querySelector('input[data-note]'));
      this.run(review.falseAlarm(input?.value ?? ''));
      if (input) input.value = '';
    } else if (target.dataset.saveNote !== undefined && this.note.draft) this.run(review.setNote(this.note.draft.text));
    else if (target.dataset.region === 'accept') this.run(review.accept());
    else if (target.dataset.region === 'redo') review.redo();
    else if (target instanceof HTMLImageElement && target.dataset.capture && target.naturalWidth) {
      const rect = target.getBoundingClientRect();
      const u = ((event.clientX - rect.left) / rect.width) * target.naturalWidth;
      const v = ((event.clientY - rect.top) / rect.height) * target.naturalHeight;
      if (event.shiftKey) {
        this.#nameTarget(u, v);
        return;
      }
      this.run(review.imageClick(this.model, u, v));
    } else return;
    this.render();
  }

  /**
   * Shift-click on the image: a new target where this pixel looks, named by the operator in the page. Made from the
   * finding that was open when clicked: another one opened meanwhile drops it.
   * @param {number} u @param {number} v
   */
  async #nameTarget(u, v) {
    const finding = this.review.selected;
    const name = await this.names.ask('Name of the new target where this pixel looks', nextName(this.model, 'target'));
    if (!name || this.review.selected !== finding) return;
    this.run(this.review.imageClick(this.model, u, v, { target: true, name }));
    this.render();
  }
}

/**
 * A note as the list shows it: its first line's worth (the card below holds it whole, up to 1000 characters).
 * @param {string} note
 */
function firstWords(note) {
  return note.length <= 90 ? note : `${note.slice(0, 90).replace(/\s+\S*$/, '')}…`;
}

/**
 * The targets, picked in order for a new mission (click to pick or unpick), and the button that starts it.
 * @param {Iterable<{id: string, name: string, kind: string}>} targets @param {string[]} picked
 * @param {string | null} robot the selected robot (a mission for it alone), or null (the fleet)
 * @param {import('../robot_groups.js').RobotGroup | null} group the group chosen in the menu: its robots alone
 */
function targetList(targets, picked, robot, group) {
  const rows = [...targets]
    .map((t) => {
      const n = picked.indexOf(t.id);
      return (
        `<li data-target="${esc(t.id)}" class="${n >= 0 ? 'active' : ''}">` +
        `<span class="order">${n >= 0 ? n + 1 : ''}</span>${esc(t.name)} <small>${esc(t.kind)}</small></li>`
      );
    })
    .join('');
  const who = group ? `with ${esc(groupTitle(group))}` : robot ? `with ${esc(robot)}` : 'with the fleet';
  const start = picked.length
    ? `<button type="button" data-mission="start">Inspect ${picked.length} ${who}</button>`
    : '<small>pick targets in order</small>';
  return `<div class="head"><b>Targets</b>${start}</div><ol class="targets">${rows}</ol>`;
}

/**
 * The schedules: what each runs, its next run, what became of its last run, its state (docs/inspection.md); for an
 * operator, Edit and Remove on each, and room for the form that makes and changes them (schedule_form.js).
 * @param {import('../protocol.js').ScheduleDescription[]} schedules @param {boolean} form whether this client has it
 */
function scheduleList(schedules, form) {
  const rows = scheduleRows(schedules);
  if (!rows.length && !form) return '';
  const buttons = (/** @type {string} */ name) =>
    form
      ? `<span class="row-buttons"><button type="button" data-schedule-edit="${esc(name)}">Edit</button>` +
        `<button type="button" data-schedule-remove="${esc(name)}">Remove</button></span>`
      : '';
  const items = rows
    .map(
      (r) =>
        `<li data-schedule="${esc(r.name)}" class="schedule ${r.tone}"><b>${esc(r.name)}</b> · ${esc(r.what)}` +
        `${buttons(r.name)}<br><small>next ${esc(r.next)} · last ${esc(r.last)} · ${esc(r.state)}</small></li>`,
    )
    .join('');
  // New schedule in the list's head: an operator's panel grows by one line for schedules until the form is opened.
  const add = form ? '<button type="button" data-schedule-new>New schedule</button>' : '';
  return (
    `<div class="head"><b>Schedules (${rows.length})</b>${add}</div><ol class="schedules">${items}</ol>` +
    (form ? '<div class="schedule-form-slot"></div>' : '')
  );
}

/**
 * The "since last round" switch and what the pins' colours say (change_colour.js).
 * @param {boolean} on
 */
function sinceSwitch(on) {
  return (
    `<p class="since"><label><input type="checkbox" data-since${on ? ' checked' : ''}> since last round</label> ` +
    '<small>pins: status colour; changed orange (small) to magenta (large); false alarm grey</small></p>'
  );
}

/**
 * A change finding's images stacked: the before (the baseline capture's) under the after, which the slider wipes
 * from the left; the change's outline stays over the after image.
 * @param {import('../inspection_model.js').Finding} f @param {string} after the after image and its overlay
 * @param {number} wipe the slider's position @param {string | null} token
 * @param {Iterable<import('../inspection_model.js').Finding>} findings those at hand, for the before's time
 */
function beforeAfter(f, after, wipe, token, findings) {
  const query = token ? `?token=${encodeURIComponent(token)}` : '';
  const labels = wipeLabels(f, findings);
  return (
    `<div class="capture wipe"><img class="before" src="${esc(`${f.before}${query}`)}" alt="before">` +
    `<div class="after">${after}</div></div>` +
    `<input type="range" data-wipe min="0" max="100" value="${wipe}" aria-label="before / after">` +
    `<p class="wipe-labels"><small>${esc(labels.before)}</small><small>${esc(labels.after)}</small></p>`
  );
}

/**
 * The trend of the finding's reading over its target's last rounds: an inline SVG sparkline (the geometry is
 * sparkline.js), the threshold a dashed line labelled with its value and unit, each round a point whose title says
 * when and what it read; nothing when the finding has no trend.
 * @param {import('../inspection_model.js').Finding} f
 */
function trendFigure(f) {
  const trend = f.trend;
  // One round is a reading, not a trend: the card says it already.
  if (!trend || trend.points.length < 2) return '';
  const { width, height, pad } = SPARK_BOX;
  const line = sparkline(trend.points, trend.threshold);
  const unit = trend.unit ? ` ${trend.unit}` : '';
  const limit =
    line.limit === null || trend.threshold === null
      ? ''
      : `<line class="limit" x1="${pad}" x2="${width - pad}" y1="${line.limit}" y2="${line.limit}"/>` +
        `<text x="${pad}" y="${labelY(line.limit)}">${esc(`${trend.threshold}${unit}`)}</text>`;
  const dots = line.points
    .map(
      (p) =>
        `<circle cx="${p.x}" cy="${p.y}" r="2.5"><title>` +
        `${esc(`${new Date(p.t * 1000).toLocaleString()}: ${p.value.toFixed(1)}${unit}`)}</title></circle>`,
    )
    .join('');
  const rounds = trend.points.length;
  const named = trend.unit ? `${trend.sensor} (${trend.unit})` : trend.sensor;
  const said = `${named} over the last ${rounds} round${rounds === 1 ? '' : 's'}`;
  return (
    `<figure class="trend"><svg viewBox="0 0 ${width} ${height}" width="${width}" height="${height}" role="img" ` +
    `aria-label="${esc(said)}">${limit}<polyline points="${polyline(line.points)}"/>${dots}</svg>` +
    `<figcaption><small>${esc(said)}${trend.threshold === null ? '' : ', its limit dashed'}</small></figcaption>` +
    '</figure>'
  );
}

/**
 * The alerts nobody acknowledged, newest first, with their count and an Acknowledge button each.
 * @param {import('../inspection_model.js').InspectionModel} model
 */
function alertList(model) {
  const alerts = model.openAlerts();
  if (!alerts.length) return '';
  const rows = alerts
    .map(
      (a) =>
        `<li data-alert="${esc(a.alert)}" class="alert ${esc(a.severity)}">${esc(a.text)}` +
        `<br><small>${esc(new Date(a.raised * 1000).toLocaleString())}</small> ` +
        `<button type="button" data-ack="${esc(a.alert)}">Acknowledge</button></li>`,
    )
    .join('');
  return (
    `<div class="head"><b>Alerts <span class="badge" title="alerts to acknowledge">${alerts.length}</span></b>` +
    `</div><ol class="alerts">${rows}</ol>`
  );
}
