// @ts-check
/**
 * The words beside the mouse cursor in Goal mode: what a click there would do (a goal for the selected robot, a
 * robot's selection, a take-over, or a refusal and its reason), the same words as the goal marker's label, which is
 * small seen from above the whole site. Hidden outside Goal mode.
 */
import { verdictText } from '../goal_verdict.js';

export class CursorTip {
  constructor() {
    this.element = document.getElementById('cursor-tip');
  }

  /**
   * Beside the cursor, what a click would do.
   * @param {import('../goal_verdict.js').GoalVerdict} outcome @param {string | null} selected the selected robot
   * @param {PointerEvent} e where the cursor is
   */
  show(outcome, selected, e) {
    const tip = this.element;
    if (!tip) return;
    const text =
      outcome.kind === 'goal'
        ? `goal for ${selected}`
        : outcome.kind === 'none'
          ? outcome.reason
          : verdictText(outcome);
    tip.textContent = text;
    tip.dataset.kind = outcome.kind;
    tip.style.left = `${e.clientX + 16}px`;
    tip.style.top = `${e.clientY + 16}px`;
    tip.hidden = !text;
  }

  /** Each frame: gone once Goal mode is. @param {boolean} goalMode */
  update(goalMode) {
    if (this.element && !this.element.hidden && !goalMode) this.element.hidden = true;
  }
}
