// @ts-check
/**
 * The operator's review of inspection, shared by the desktop's findings list and the VR finding card: which
 * finding is open, the region asked of the relay and the outline it proposed (accept or redo), what a click on
 * the image does (mark a region, or make a target where that pixel looks), and the targets picked in order for
 * a new mission. No DOM, no WebGL: every act returns the commands to send (the page carries them out), and
 * test/inspection_review.test.js drives it with the relay's message shapes.
 */

/** @typedef {import('./protocol.js').FindingStatus} FindingStatus */
/**
 * @typedef {{type: 'finding_update', finding: string, fields: {status?: FindingStatus, note?: string,
 *   region?: number[][]}}
 *   | {type: 'region', capture: string, u: number, v: number}
 *   | {type: 'target_pixel', target: string, capture: string, u: number, v: number}
 *   | {type: 'target_at', target: string, x: number, y: number}
 *   | {type: 'target_live', target: string, robot: string, u: number, v: number}
 *   | {type: 'mission_targets', targets: string[], robot: string | null, robots: string[] | null}
 *   | {type: 'findings_page', before: number | null} | {type: 'alert_ack', alert: string}} ReviewCommand
 */

export const FINDING_STATUSES = /** @type {const} */ (['anomaly', 'changed', 'needs_review', 'ok', 'false_alarm']);
/** The longest note the relay keeps (relay/inspection/wire.py MAX_NOTE). */
export const MAX_NOTE = 1000;

/**
 * A dictated phrase added to a note: after it, one space apart, the whole within the relay's limit.
 * @param {string} note @param {string} phrase
 */
export function appendNote(note, phrase) {
  return [note.trim(), phrase.trim()].filter(Boolean).join(' ').slice(0, MAX_NOTE);
}

/**
 * A target's identifier from what an operator typed: letters, digits, - and _ (the relay's rule), at most 64.
 * @param {string} text
 */
export function targetName(text) {
  return text
    .trim()
    .replace(/[^A-Za-z0-9_-]+/g, '-')
    .replace(/^-+|-+$/g, '')
    .slice(0, 64);
}

export class InspectionReview {
  /** The finding open in the list or on the card. @type {string | null} */
  selected = null;
  /** The region request awaiting its outline. @type {{request: string, finding: string} | null} */
  pending = null;
  /** The outline the relay proposed, to accept or redo. @type {number[][] | null} */
  proposal = null;
  /** What a click (a select in VR) on the image does. @type {'region' | 'target'} */
  imageAction = 'region';
  /** Targets picked for a new mission, in order. @type {string[]} */
  picked = [];
  /**
   * A target marked on the live image, awaiting its finding and region.
   * @type {{request: string, target: string} | null}
   */
  live = null;
  /** What went wrong with the last region asked, said under the image until the next act. */
  note = '';
  /** Bumped on every change, so views redraw only when something changed. */
  version = 0;

  /**
   * Follow the model: targets that vanished are unpicked, a finding that vanished closes, and the outline of
   * the pending request becomes the proposal once the relay sent it.
   * @param {import('./inspection_model.js').InspectionModel} model
   */
  sync(model) {
    const picked = this.picked.filter((t) => model.targets.has(t));
    if (picked.length !== this.picked.length) this.#change(() => (this.picked = picked));
    if (this.selected !== null && !model.findings.has(this.selected)) this.select(null);
    // A target marked on the live image: its finding opens (the relay sent it, and the region it proposes, before
    // the ack); refused, the relay's error says why (a toast) and nothing opens.
    const live = this.live;
    const ok = live ? model.settled.get(live.request) : undefined;
    if (live && ok === undefined && !model.awaiting.has(live.request))
      this.#change(() => (this.live = null)); // a new relay
    else if (live && ok !== undefined) {
      const finding = ok ? model.list().find((f) => f.target === live.target && f.source === 'operator') : undefined;
      this.#change(() => (this.live = null));
      if (finding) {
        this.select(finding.id);
        this.#change(() => (this.pending = { request: live.request, finding: finding.id }));
      }
    }
    const outline = this.pending ? model.regions.get(this.pending.request) : undefined;
    if (outline) this.#change(() => ((this.proposal = outline), (this.pending = null)));
    else if (this.pending && model.settled.has(this.pending.request)) {
      // Answered without an outline: nothing to segment there (or refused); the next point asks again.
      this.#change(
        () => ((this.pending = null), (this.note = 'no region found there: select a point of the image to mark one')),
      );
    }
  }

  /** Open a finding (null: close); a region being marked on another one is dropped. @param {string | null} finding */
  select(finding) {
    if (finding === this.selected) return;
    this.#change(() => {
      this.selected = finding;
      this.proposal = null;
      this.pending = null;
      this.note = '';
      this.imageAction = 'region';
    });
  }

  /**
   * A point of the selected robot's live camera image (a gaze dwell on the hemisphere): a new target where it
   * looks, a finding about a capture taken now, and the region around the point proposed on it.
   * @param {import('./inspection_model.js').InspectionModel} model @param {string} robot
   * @param {number} u @param {number} v pixel of the camera's configured size
   * @returns {ReviewCommand[]}
   */
  liveClick(model, robot, u, v) {
    if (this.live) return []; // one at a time: the first is still being captured
    return [{ type: 'target_live', target: nextName(model, 'spot'), robot, u, v }];
  }

  /**
   * The target from the live image was asked (its request id, for the answer). @param {string} request
   * @param {string} target
   */
  liveAsked(request, target) {
    this.#change(() => (this.live = { request, target }));
  }

  /** Pick a target for the next mission, or unpick it. @param {string} target */
  togglePick(target) {
    this.#change(
      () =>
        (this.picked = this.picked.includes(target)
          ? this.picked.filter((t) => t !== target)
          : [...this.picked, target]),
    );
  }

  /**
   * The picked targets as a mission, for one robot, for a group of robots (``robots``) or for the fleet (both null).
   * @param {string | null} robot @param {string[] | null} [robots] @returns {ReviewCommand[]}
   */
  startPicked(robot, robots = null) {
    if (this.picked.length === 0) return [];
    return [{ type: 'mission_targets', targets: [...this.picked], robot, robots }];
  }

  /** The mission was sent: the picks are spent. */
  picksSent() {
    this.#change(() => (this.picked = []));
  }

  /** @param {'region' | 'target'} action */
  setImageAction(action) {
    if (action !== this.imageAction) this.#change(() => (this.imageAction = action));
  }

  /** Set the open finding's status. @param {FindingStatus} status @returns {ReviewCommand[]} */
  setStatus(status) {
    return this.selected ? [{ type: 'finding_update', finding: this.selected, fields: { status } }] : [];
  }

  /**
   * The note of the open finding (or of ``finding``, for a dictation that ends after the card moved on): up to the
   * relay's 1000 characters, trimmed; "" clears it.
   * @param {string} note @param {string | null} [finding] @returns {ReviewCommand[]}
   */
  setNote(note, finding = this.selected) {
    return finding ? [{ type: 'finding_update', finding, fields: { note: note.trim().slice(0, MAX_NOTE) } }] : [];
  }

  /**
   * Mark the open finding a false alarm, saying why (a shadow, a passer-by): the relay then compares the target's
   * next round with the image accepted before it (docs/inspection.md). An empty note leaves the note as it was.
   * @param {string} note @returns {ReviewCommand[]}
   */
  falseAlarm(note) {
    if (!this.selected) return [];
    const why = note.trim().slice(0, MAX_NOTE);
    const fields = why
      ? { status: /** @type {const} */ ('false_alarm'), note: why }
      : { status: /** @type {const} */ ('false_alarm') };
    return [{ type: 'finding_update', finding: this.selected, fields }];
  }

  /**
   * A click on the open finding's image, at a pixel of the capture: a region to segment there, or (the image
   * action 'target', or shift on the desktop) a target where that pixel looks, named `name`.
   * @param {import('./inspection_model.js').InspectionModel} model
   * @param {number} u @param {number} v pixel of the capture's image
   * @param {{target?: boolean, name?: string}} [options]
   * @returns {ReviewCommand[]}
   */
  imageClick(model, u, v, options = {}) {
    const finding = this.selected ? model.findings.get(this.selected) : null;
    if (!finding) return [];
    if (options.target ?? this.imageAction === 'target') {
      const name = targetName(options.name ?? nextName(model, 'spot'));
      if (!name) return [];
      this.setImageAction('region');
      return [{ type: 'target_pixel', target: name, capture: finding.capture, u, v }];
    }
    if (this.note) this.#change(() => (this.note = ''));
    return [{ type: 'region', capture: finding.capture, u, v }];
  }

  /** The relay was asked to segment (its request id, for the outline that answers). @param {string} request */
  regionAsked(request) {
    if (this.selected)
      this.#change(
        () => ((this.pending = { request, finding: /** @type {string} */ (this.selected) }), (this.proposal = null)),
      );
  }

  /** Whether an outline on the open finding's image waits to be judged (proposed, or asked for). */
  get judging() {
    return this.proposal !== null || this.pending !== null;
  }

  /** Keep the proposed outline as the open finding's region. @returns {ReviewCommand[]} */
  accept() {
    if (!this.selected || !this.proposal) return [];
    const commands = /** @type {ReviewCommand[]} */ ([
      { type: 'finding_update', finding: this.selected, fields: { region: this.proposal } },
    ]);
    this.#change(() => (this.proposal = null));
    return commands;
  }

  /** Drop the proposed outline: the next click on the image asks again. */
  redo() {
    if (this.proposal || this.pending) this.#change(() => ((this.proposal = null), (this.pending = null)));
  }

  /**
   * The outline to draw over the open finding's image: the proposal, else the region it has.
   * @param {import('./inspection_model.js').InspectionModel} model
   */
  outline(model) {
    const finding = this.selected ? model.findings.get(this.selected) : null;
    return this.proposal ?? finding?.region ?? null;
  }

  /** What the operator is asked to do next with the open finding's image (a hint under it). */
  hint() {
    if (this.pending) return 'segmenting…';
    if (this.note) return this.note;
    if (this.proposal) return 'keep this region? Accept, or Redo and point again';
    return this.imageAction === 'target'
      ? 'select a point of the image: a new target there'
      : 'select a point of the image to mark a region';
  }

  /** @param {() => void} fn */
  #change(fn) {
    fn();
    this.version++;
  }
}

/**
 * The first free name `<base>-N` among the model's targets (a target made where no keyboard is at hand).
 * @param {import('./inspection_model.js').InspectionModel} model @param {string} base
 */
export function nextName(model, base) {
  for (let n = model.targets.size + 1; ; n++) if (!model.targets.has(`${base}-${n}`)) return `${base}-${n}`;
}
