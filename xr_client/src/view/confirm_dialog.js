// @ts-check
/**
 * The page's own yes-or-no question (`#confirm-dialog` of index.html), never `window.confirm`, which held the whole
 * page while open: no frame, and E-STOP's keys with it (tests/e2e/test_page_dialogs.py). Opened without a modal
 * backdrop, as the target and take-over dialogs are, so the E-STOP button stays clickable; Esc and Enter answer no
 * (Esc is still the page's E-STOP: view/desktop_keys.js); only a click on the yes button says yes.
 */

import { InPageQuestion } from './in_page_question.js';

export class ConfirmDialog {
  /** @param {HTMLDialogElement | null} element `#confirm-dialog` (null: no page, every question answered no) */
  constructor(element) {
    this.element = element;
    this.text = element?.querySelector('p') ?? null;
    this.yes = /** @type {HTMLButtonElement | null} */ (element?.querySelector('button[value="yes"]') ?? null);
    this.no = /** @type {HTMLButtonElement | null} */ (element?.querySelector('button[value="no"]') ?? null);
    /** @type {InPageQuestion<boolean>} */
    this.question = new InPageQuestion(element, (value) => value === 'yes', false, 'no');
  }

  get open() {
    return this.question.open;
  }

  /**
   * Ask; resolves true when the operator presses the yes button. Asking again while open answers the earlier
   * question no.
   * @param {string} question @param {string} yes the yes button's words ("Remove") @returns {Promise<boolean>}
   */
  ask(question, yes) {
    if (!this.element) return Promise.resolve(false);
    if (this.text) this.text.textContent = question;
    if (this.yes) this.yes.textContent = yes;
    const answer = this.question.show();
    this.no?.focus(); // Enter keeps what there is: the question is asked before something is undone
    return answer;
  }

  dispose() {
    this.question.dispose();
  }
}
