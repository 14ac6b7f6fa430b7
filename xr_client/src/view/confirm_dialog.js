// @ts-check
/**
 * The page's own yes-or-no question (`#confirm-dialog` of index.html), never `window.confirm`, which held the whole
 * page while open: no frame, and E-STOP's keys with it (tests/e2e/test_page_dialogs.py). Opened without a modal
 * backdrop, as the target and take-over dialogs are, so the E-STOP button stays clickable; Esc and Enter answer no
 * (Esc is still the page's E-STOP: view/desktop_keys.js); only a click on the yes button says yes.
 */

export class ConfirmDialog {
  /** @param {HTMLDialogElement | null} element `#confirm-dialog` (null: no page, every question answered no) */
  constructor(element) {
    this.element = element;
    this.text = element?.querySelector('p') ?? null;
    this.yes = /** @type {HTMLButtonElement | null} */ (element?.querySelector('button[value="yes"]') ?? null);
    this.no = /** @type {HTMLButtonElement | null} */ (element?.querySelector('button[value="no"]') ?? null);
    /** Who waits for the answer of the question open now. @type {((yes: boolean) => void) | null} */
    this.resolve = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    if (!element) return;
    const onClose = () => this.#answer(element.returnValue === 'yes');
    const onKey = (/** @type {KeyboardEvent} */ e) => {
      if (e.code === 'Escape') element.close('no'); // show() gives a dialog no Esc of its own
    };
    element.addEventListener('close', onClose);
    element.addEventListener('keydown', onKey);
    this.unlisten.push(
      () => element.removeEventListener('close', onClose),
      () => element.removeEventListener('keydown', onKey),
    );
  }

  get open() {
    return Boolean(this.element?.open);
  }

  /**
   * Ask; resolves true when the operator presses the yes button. Asking again while open answers the earlier
   * question no.
   * @param {string} question @param {string} yes the yes button's words ("Remove") @returns {Promise<boolean>}
   */
  ask(question, yes) {
    const element = this.element;
    if (!element) return Promise.resolve(false);
    this.#answer(false);
    if (this.text) this.text.textContent = question;
    if (this.yes) this.yes.textContent = yes;
    element.returnValue = '';
    if (!element.open) element.show();
    this.no?.focus(); // Enter keeps what there is: the question is asked before something is undone
    return new Promise((resolve) => (this.resolve = resolve));
  }

  /** @param {boolean} yes */
  #answer(yes) {
    const resolve = this.resolve;
    this.resolve = null;
    resolve?.(yes);
  }

  dispose() {
    this.#answer(false);
    for (const off of this.unlisten) off();
    this.unlisten = [];
    if (this.element?.open) this.element.close();
  }
}
