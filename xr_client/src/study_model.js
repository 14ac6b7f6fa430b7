// @ts-check
/**
 * The study the relay runs (docs/study.md), as the page shows it: the relay's `study` message, the time left counted
 * on the page's clock from the message's `elapsed`, and the participant's answers being given (the SUS's ten items
 * 1-5, the raw NASA-TLX's six scales 0-100) until they are sent. Pure: `apply` returns effects (as
 * message_router.js does), the answers return the command to send or why not; view/study_panel.js draws it and
 * test/study_model.test.js drives it.
 *
 * In the headset, where the page's panel is not seen, the question asked now is the VR menu's (`menuQuestion`: its
 * words, then its answers as buttons, a pointer's, a pinch's or a glance's), one SUS item or TLX scale at a time;
 * `pressMenu` takes those buttons' presses.
 */

/**
 * @typedef {import('./protocol.js').StudyMessage} StudyMessage
 * @typedef {{type: 'study'}
 *   | {type: 'notify', text: string, kind: 'info' | 'error' | 'warning', toast: boolean}
 *   | {type: 'condition', muted: boolean | null, ask: string}} StudyEffect `condition`: a new condition's page settings
 *   (the study file's `client`): the sound on or off (null: as it is), and what the participant is asked to do that a
 *   page cannot do by itself (put on the headset, use the hands), '' when nothing
 * @typedef {Omit<import('./protocol.js').StudyJoinCommand, 'id'>
 *   | Omit<import('./protocol.js').StudyStartCommand, 'id'>
 *   | Omit<import('./protocol.js').StudyQuestionnaireAnswerCommand, 'id'>
 *   | Omit<import('./protocol.js').StudyProbeAnswerCommand, 'id'>} StudyCommand
 */

/** The System Usability Scale's items (Brooke, 1996), answered 1 (strongly disagree) to 5 (strongly agree). */
export const SUS_ITEMS = Object.freeze([
  'I think that I would like to use this system frequently.',
  'I found the system unnecessarily complex.',
  'I thought the system was easy to use.',
  'I think that I would need the support of a technical person to be able to use this system.',
  'I found the various functions in this system were well integrated.',
  'I thought there was too much inconsistency in this system.',
  'I would imagine that most people would learn to use this system very quickly.',
  'I found the system very cumbersome to use.',
  'I felt very confident using the system.',
  'I needed to learn a lot of things before I could get going with this system.',
]);

/** The raw NASA-TLX's scales (Hart, 2006), 0-100 in steps of 5, with their ends as the form words them. */
export const TLX_SCALES = Object.freeze([
  { name: 'mental', question: 'How mentally demanding was the task?', low: 'Very low', high: 'Very high' },
  { name: 'physical', question: 'How physically demanding was the task?', low: 'Very low', high: 'Very high' },
  { name: 'temporal', question: 'How hurried or rushed was the pace of the task?', low: 'Very low', high: 'Very high' },
  {
    name: 'performance',
    question: 'How successful were you in accomplishing what you were asked to do?',
    low: 'Perfect',
    high: 'Failure',
  },
  {
    name: 'effort',
    question: 'How hard did you have to work to accomplish your level of performance?',
    low: 'Very low',
    high: 'Very high',
  },
  {
    name: 'frustration',
    question: 'How insecure, discouraged, irritated, stressed and annoyed were you?',
    low: 'Very low',
    high: 'Very high',
  },
]);
/** Where a TLX slider starts: the middle, so that an untouched scale is visible as one. */
export const TLX_START = 50;
/** The VR menu's TLX buttons: the scale's ends, its quarters, and a step of 5 either way. */
const TLX_PRESETS = [0, 25, 50, 75, 100];
/** The SUS's answers as the VR menu labels them. */
const SUS_LABELS = ['1 Disagree', '2', '3', '4', '5 Agree'];

/**
 * The question the VR menu shows: its words (one line each), its answers and how to move between items and send.
 * @typedef {{id: string, label: string, active: boolean, enabled: boolean}} QuestionButton
 * @typedef {{lines: string[], answers: QuestionButton[], moves: QuestionButton[]}} MenuQuestion
 */

export class StudyModel {
  /** The relay's newest `study` message (null: the relay runs no study). @type {StudyMessage | null} */
  message = null;
  /** When it came (page ms): the time left counts on from its `elapsed`. */
  receivedAt = 0;
  /** The SUS answers given so far (null: not yet). @type {(number | null)[]} */
  sus = SUS_ITEMS.map(() => null);
  /** The TLX scales as set. @type {number[]} */
  tlx = TLX_SCALES.map(() => TLX_START);
  /** The participant picked to join. */
  participant = '';
  /** The SUS item or TLX scale the VR menu shows (0-based). */
  item = 0;

  /**
   * @param {StudyMessage} message @param {number} now page ms @returns {StudyEffect[]}
   */
  apply(message, now) {
    const before = this.message;
    this.message = message;
    this.receivedAt = now;
    if (!this.participant || !message.participants.includes(this.participant))
      this.participant = message.participant ?? message.participants[0] ?? '';
    const asked = message.phase === 'questions' ? message.questionnaire : null;
    const wasAsked = before?.phase === 'questions' ? before.questionnaire : null;
    if (asked !== wasAsked || before?.task !== message.task || before?.condition !== message.condition) this.#fresh();
    /** @type {StudyEffect[]} */
    const effects = [{ type: 'study' }];
    // A condition starts for the participant (joined, or the next in their order): the page takes its settings.
    const joined = message.participant !== null && message.condition !== null;
    if (joined && (message.condition !== before?.condition || message.participant !== before?.participant))
      effects.push(conditionEffect(/** @type {string} */ (message.condition), message.settings));
    if (before?.phase === 'task' && message.phase === 'questions' && message.questionnaire !== null)
      effects.push({
        type: 'notify',
        text: `Task ${before.task} over: please answer the questions`,
        kind: 'info',
        toast: true,
      });
    if (before?.phase === 'task' && message.phase === 'probe')
      effects.push({
        type: 'notify',
        text: 'A question about the robots: the task is paused',
        kind: 'info',
        toast: true,
      });
    return effects;
  }

  /** New answers for a new questionnaire. */
  #fresh() {
    this.sus = SUS_ITEMS.map(() => null);
    this.tlx = TLX_SCALES.map(() => TLX_START);
    this.item = 0;
  }

  /** The question asked now as the VR menu shows it, or null (none asked). @returns {MenuQuestion | null} */
  menuQuestion() {
    const m = this.message;
    if (m?.phase === 'probe' && m.probe) {
      const answers = m.probe.choices.map((c) => ({ id: `study:probe:${c}`, label: c, active: false, enabled: true }));
      return { lines: splitLine(probeQuestion(m.probe)), answers, moves: [] };
    }
    const asked = m?.phase === 'questions' ? m.questionnaire : null;
    if (asked !== 'sus' && asked !== 'tlx') return null;
    const count = asked === 'sus' ? SUS_ITEMS.length : TLX_SCALES.length;
    const i = Math.min(this.item, count - 1);
    /** @type {QuestionButton[]} */
    let answers;
    let text;
    if (asked === 'sus') {
      text = `SUS ${i + 1}/${count}: ${SUS_ITEMS[i]}`;
      answers = SUS_LABELS.map((label, k) => ({ id: `study:sus:${k + 1}`, label, active: this.sus[i] === k + 1,
                                                enabled: true })); // prettier-ignore
    } else {
      const scale = TLX_SCALES[i];
      text = `TLX ${i + 1}/${count}: ${scale.question} Now ${this.tlx[i]} (0 ${scale.low}, 100 ${scale.high})`;
      answers = [
        ...TLX_PRESETS.map((v) => ({
          id: `study:tlx:${v}`,
          label: String(v),
          active: this.tlx[i] === v,
          enabled: true,
        })),
        { id: 'study:tlx:-5', label: '−5', active: false, enabled: this.tlx[i] > 0 },
        { id: 'study:tlx:+5', label: '+5', active: false, enabled: this.tlx[i] < 100 },
      ];
    }
    const moves = [
      { id: 'study:prev', label: '‹ Back', active: false, enabled: i > 0 },
      { id: 'study:next', label: 'Next ›', active: false, enabled: i < count - 1 },
      { id: 'study:send', label: 'Send answers', active: false, enabled: !('missing' in this.answer()) },
    ];
    return { lines: splitLine(text), answers, moves };
  }

  /**
   * A press of the VR menu's question buttons: the answer set (a SUS answer moves on to the next item), or the
   * command to send (the probe's choice, the questionnaire's answers), or why not.
   * @param {string} id @returns {{command: StudyCommand} | {missing: string} | {}}
   */
  pressMenu(id) {
    const [, kind, value] = id.split(':');
    const asked = this.message?.phase === 'questions' ? this.message.questionnaire : null;
    if (kind === 'probe') {
      const command = this.answerProbe(value);
      return command ? { command } : { missing: 'that is not one of the answers' };
    }
    if (kind === 'send') return this.answer();
    const count = asked === 'sus' ? SUS_ITEMS.length : TLX_SCALES.length;
    if (kind === 'prev') this.item = Math.max(0, this.item - 1);
    else if (kind === 'next') this.item = Math.min(count - 1, this.item + 1);
    else if (kind === 'sus' && asked === 'sus') {
      this.setSus(this.item, Number(value));
      this.item = Math.min(count - 1, this.item + 1);
    } else if (kind === 'tlx' && asked === 'tlx') {
      const step = value === '+5' ? 5 : value === '-5' ? -5 : null;
      this.setTlx(this.item, step === null ? Number(value) : this.tlx[this.item] + step);
    }
    return {};
  }

  /** Seconds left in the task running now (counted on the page's clock), else null. @param {number} now page ms */
  timeLeft(now) {
    const m = this.message;
    if (!m || m.phase !== 'task' || m.time_limit === null) return null;
    return Math.max(0, m.time_limit - m.elapsed - (now - this.receivedAt) / 1000);
  }

  /** @param {string} participant */
  choose(participant) {
    this.participant = participant;
  }

  /** @returns {StudyCommand | null} */
  join() {
    return this.participant ? { identifier: 'study/join', participant: this.participant } : null;
  }

  /** @returns {StudyCommand | null} */
  start() {
    return this.message?.phase === 'ready' ? { identifier: 'study/start' } : null;
  }

  /** @param {number} item 0-9 @param {number} answer 1-5 */
  setSus(item, answer) {
    if (item >= 0 && item < SUS_ITEMS.length && Number.isInteger(answer) && answer >= 1 && answer <= 5)
      this.sus[item] = answer;
  }

  /** @param {number} scale 0-5 @param {number} value 0-100 */
  setTlx(scale, value) {
    if (scale >= 0 && scale < TLX_SCALES.length && Number.isFinite(value))
      this.tlx[scale] = Math.min(100, Math.max(0, Math.round(value / 5) * 5));
  }

  /** The questionnaire asked now: its answers to send, or why they cannot be yet. @returns {{command: StudyCommand}
   *   | {missing: string}} */
  answer() {
    const asked = this.message?.phase === 'questions' ? this.message.questionnaire : null;
    if (asked === null || asked === undefined) return { missing: 'no questionnaire is asked now' };
    if (asked === 'tlx')
      return { command: { identifier: 'study/answer', questionnaire: 'tlx', answers: [...this.tlx] } };
    const unanswered = this.sus.flatMap((a, i) => (a === null ? [i + 1] : []));
    if (unanswered.length)
      return { missing: `please answer item${unanswered.length > 1 ? 's' : ''} ${unanswered.join(', ')}` };
    return { command: { identifier: 'study/answer', questionnaire: 'sus', answers: this.sus.map(Number) } };
  }

  /** @param {string} choice @returns {StudyCommand | null} */
  answerProbe(choice) {
    const probe = this.message?.phase === 'probe' ? this.message.probe : null;
    return probe && probe.choices.includes(choice) ? { identifier: 'study/answer', probe: choice } : null;
  }
}

/** Where a long question breaks onto a second line (characters): the VR menu's row holds about this many. */
const LINE_CHARS = 60;

/**
 * A question in one line, or two broken at a space near the middle when it is long.
 * @param {string} text @returns {string[]}
 */
export function splitLine(text) {
  if (text.length <= LINE_CHARS) return [text];
  const middle = text.length / 2;
  let cut = -1;
  for (let i = 0; i < text.length; i++)
    if (text[i] === ' ' && (cut < 0 || Math.abs(i - middle) < Math.abs(cut - middle))) cut = i;
  return cut < 0 ? [text] : [text.slice(0, cut), text.slice(cut + 1)];
}

/** Seconds as m:ss. @param {number} seconds @returns {string} */
export function clockText(seconds) {
  const s = Math.ceil(seconds);
  return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, '0')}`;
}

/** A probe's question in words. @param {import('./protocol.js').StudyProbe} probe @returns {string} */
export function probeQuestion(probe) {
  if (probe.question === 'room') return `Which room is ${probe.robot} in?`;
  if (probe.question === 'mode') return `What is ${probe.robot} doing?`;
  return `Which robot is nearest to ${probe.robot}?`;
}

/**
 * What the page does as a condition starts: the sound as the condition sets it; the view and the input, which only
 * the participant can change (entering VR needs their gesture), asked of them.
 * @param {string} condition @param {Record<string, string>} settings the study file's `client` (docs/study.md)
 * @returns {StudyEffect}
 */
export function conditionEffect(condition, settings) {
  const muted = settings.sound === 'off' ? true : settings.sound === 'on' ? false : null;
  const asks = [];
  if (settings.view === 'headset') asks.push('put on the headset (Enter VR)');
  if (settings.view === 'desktop') asks.push('stay at the desktop');
  if (settings.input === 'hands') asks.push('use your hands, controllers down');
  if (settings.input === 'controllers') asks.push('use the controllers');
  return { type: 'condition', muted, ask: asks.length ? `Condition ${condition}: ${asks.join(', ')}` : '' };
}
