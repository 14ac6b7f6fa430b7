// @ts-check
/**
 * The in-page dialog that names a new inspection target (a shift-click on the floor, or on a finding's image).
 * It replaced `window.prompt`, which blocked the whole page while open: Space and Esc could not reach E-STOP, the
 * frame loop stopped, and the teleop clock with it. This one is a `<dialog>` opened without a modal backdrop, so the
 * page keeps drawing and its E-STOP button stays clickable: Enter names the target, Esc or **Cancel** drops it (and
 * Esc is still the page's E-STOP: desktop_controls.js), Space is E-STOP too (a target's name has no spaces).
 */
import { targetName } from '../inspection_review.js';

export class TargetDialog {
  /** @param {HTMLDialogElement | null} element `#target-dialog` of index.html (null: no page, no dialog) */
  constructor(element) {
    this.element = element;
    this.input = /** @type {HTMLInputElement | null} */ (element?.querySelector('input') ?? null);
    this.text = element?.querySelector('.prompt') ?? null;
    /** Who waits for the answer of the dialog open now. @type {((name: string | null) => void) | null} */
    this.resolve = null;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    if (!element) return;
    const onClose = () =>
      this.#answer(element.returnValue === 'ok' ? targetName(this.input?.value ?? '') || null : null);
    const onKey = (/** @type {KeyboardEvent} */ e) => {
      // A dialog opened with show() has no Esc of its own (showModal's would bring a backdrop that takes every click).
      if (e.code === 'Escape') element.close('cancel');
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
   * Ask for a target's name; resolves with it (cleaned to letters, digits, - and _), or null when cancelled. Asking
   * again while open answers the earlier question with null.
   * @param {string} prompt what the target is (where it will be) @param {string} suggestion the name offered
   * @returns {Promise<string | null>}
   */
  ask(prompt, suggestion) {
    const element = this.element;
    if (!element || !this.input) return Promise.resolve(null);
    this.#answer(null);
    if (this.text) this.text.textContent = prompt;
    this.input.value = suggestion;
    element.returnValue = '';
    if (!element.open) element.show();
    this.input.focus();
    this.input.select();
    return new Promise((resolve) => (this.resolve = resolve));
  }

  /** @param {string | null} name */
  #answer(name) {
    const resolve = this.resolve;
    this.resolve = null;
    resolve?.(name);
  }

  dispose() {
    this.#answer(null);
    for (const off of this.unlisten) off();
    this.unlisten = [];
    if (this.element?.open) this.element.close();
  }
}
