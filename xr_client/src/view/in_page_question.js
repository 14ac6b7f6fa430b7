// @ts-check
/**
 * What the page's own dialogs share (target_dialog.js, confirm_dialog.js): a `<dialog>` opened with `show()`, without
 * a modal backdrop, so the page keeps drawing and its E-STOP button stays clickable. `show()` gives a dialog no Esc of
 * its own (`showModal`'s would bring a backdrop that takes every click): Esc closes it with the cancel value here, and
 * is still the page's E-STOP (view/desktop_keys.js). One question at a time: asking again answers the earlier one as
 * cancelled.
 * @template T
 */
export class InPageQuestion {
  /**
   * @param {HTMLDialogElement | null} element (null: no page, every question answered with `cancelled`)
   * @param {(returnValue: string) => T} answerOf the answer a closed dialog gives, from its return value
   * @param {T} cancelled the answer of a question cancelled (Esc, asked again, disposed)
   * @param {string} cancelValue the return value Esc closes the dialog with
   */
  constructor(element, answerOf, cancelled, cancelValue) {
    this.element = element;
    this.cancelled = cancelled;
    /** Who waits for the answer of the question open now. @type {((answer: T) => void) | null} */
    this.resolve = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    if (!element) return;
    const onClose = () => this.answer(answerOf(element.returnValue));
    const onKey = (/** @type {KeyboardEvent} */ e) => {
      if (e.code === 'Escape') element.close(cancelValue);
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

  /** Open the dialog (the caller has filled it); the answer when it closes. @returns {Promise<T>} */
  show() {
    const element = this.element;
    if (!element) return Promise.resolve(this.cancelled);
    this.answer(this.cancelled);
    element.returnValue = '';
    if (!element.open) element.show();
    return new Promise((resolve) => (this.resolve = resolve));
  }

  /** @param {T} value */
  answer(value) {
    const resolve = this.resolve;
    this.resolve = null;
    resolve?.(value);
  }

  dispose() {
    this.answer(this.cancelled);
    for (const off of this.unlisten) off();
    this.unlisten = [];
    if (this.element?.open) this.element.close();
  }
}
