// @ts-check
/**
 * A finding's note on the desktop card, written and changed in place (Space types a space here: data-space, where
 * elsewhere it is the E-STOP). What is typed is a draft kept across the panel's redraws (any finding or alert that
 * arrives redraws it) until the relay holds it; Save note sends it (the inspection review's setNote).
 */
import { MAX_NOTE } from '../inspection_review.js';
import { esc } from './html.js';

export class NoteEditor {
  /** The note being written, until the relay has it. @type {{finding: string, text: string} | null} */
  draft = null;

  /**
   * The editor for ``f``: a draft the relay now holds (or of another finding) is dropped first.
   * @param {import('../protocol.js').FindingMessage} f
   */
  html(f) {
    if (this.draft && (this.draft.finding !== f.id || this.draft.text.trim() === f.note)) this.draft = null;
    const text = this.draft?.text ?? f.note;
    return (
      `<div class="note"><textarea data-finding-note data-space="text" maxlength="${MAX_NOTE}" rows="4" ` +
      `aria-label="note" placeholder="a note: what was seen, what to do">${esc(text)}</textarea>` +
      `<p><button type="button" data-save-note${this.draft ? '' : ' disabled'}>Save note</button> ` +
      `<small data-note-count>${text.length} / ${MAX_NOTE}</small></p></div>`
    );
  }

  /**
   * A key typed in ``f``'s note: the draft, its count and its Save button, without a redraw.
   * @param {ParentNode} root @param {import('../protocol.js').FindingMessage} f @param {string} value
   */
  typed(root, f, value) {
    this.draft = value === f.note ? null : { finding: f.id, text: value };
    const count = root.querySelector('[data-note-count]');
    if (count) count.textContent = `${value.length} / ${MAX_NOTE}`;
    const save = /** @type {HTMLButtonElement | null} */ (root.querySelector('button[data-save-note]'));
    if (save) save.disabled = this.draft === null;
  }
}
