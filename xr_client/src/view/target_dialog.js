// @ts-check
/**
 * The in-page dialog that names a new inspection target (a shift-click on the floor, or on a finding's image).
 * It replaced `window.prompt`, which blocked the whole page while open: Space and Esc could not reach E-STOP, the
 * frame loop stopped, and the teleop clock with it. This one is a `<dialog>` opened without a modal backdrop, so the
 * page keeps drawing and its E-STOP button stays clickable: Enter names the target, Esc or **Cancel** drops it (and
 * Esc is still the page's E-STOP: desktop_controls.js), Space is E-STOP too (a target's name has no spaces).
 */
import { targetName } from '../inspection_review.js';
import { InPageQuestion } from './in_page_question.js';

export class TargetDialog {
  /** @param {HTMLDialogElement | null} element `#target-dialog` of index.html (null: no page, no dialog) */
  constructor(element) {
    this.element = element;
    this.input = /** @type {HTMLInputElement | null} */ (element?.querySelector('input') ?? null);
    this.text = element?.querySelector('.prompt') ?? null;
    /** @type {InPageQuestion<string | null>} */
    this.question = new InPageQuestion(
      element,
      (value) => (value === 'ok' ? targetName(this.input?.value ?? '') || null : null),
      null,
      'cancel',
    );
  }

  get open() {
    return this.question.open;
  }

  /**
   * Ask for a target's name; resolves with it (cleaned to letters, digits, - and _), or null when cancelled. Asking
   * again while open answers the earlier question with null.
   * @param {string} prompt what the target is (where it will be) @param {string} suggestion the name offered
   * @returns {Promise<string | null>}
   */
  ask(prompt, suggestion) {
    if (!this.element || !this.input) return Promise.resolve(null);
    if (this.text) this.text.textContent = prompt;
    this.input.value = suggestion;
    const answer = this.question.show();
    this.input.focus();
    this.input.select();
    return answer;
  }

  dispose() {
    this.question.dispose();
  }
}
