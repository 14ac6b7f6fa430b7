// @ts-check
/**
 * The desktop menu's row for groups of robots (robot_groups.js: each team, each room with robots in it): choose one,
 * then Stop group latches an E-STOP on each of its robots, Cancel goals cancels each one's goal, and the findings
 * panel's Inspect sends the picked targets to the group's robots alone (mission/start with `robots`). Each robot's
 * stop is the relay's own per-robot E-STOP, refused or latched one by one as the menu's would be. The row is kept
 * (never rebuilt while the list is open) and shows only when there is a group to choose.
 */
import { may } from '../roles.js';
import { groupTitle } from '../robot_groups.js';

/** How often the groups are worked out again while robots move between rooms (ms). */
const REFRESH_MS = 500;

export class GroupBar {
  /**
   * @param {{menu: import('../menu_state.js').MenuState, groups: () => import('../robot_groups.js').RobotGroup[],
   *   stop: (robots: string[]) => void, cancel: (robots: string[]) => void,
   *   chosen: (group: import('../robot_groups.js').RobotGroup | null) => void}} host
   */
  constructor(host) {
    this.host = host;
    this.element = document.createElement('div');
    this.element.className = 'row group';
    this.select = document.createElement('select');
    this.select.setAttribute('aria-label', 'Group of robots');
    this.stopButton = this.#button('stop', 'Stop group');
    this.stopButton.classList.add('estop');
    this.cancelButton = this.#button('cancel', 'Cancel goals');
    this.element.append(this.select, this.stopButton, this.cancelButton);
    /** @type {import('../robot_groups.js').RobotGroup[]} */
    this.groups = [];
    /** The group chosen (by id: a room's robots change as they move), or null. @type {string | null} */
    this.chosenId = null;
    this.key = '';
    this.drawn = -Infinity;
    this.onChange = () => {
      this.chosenId = this.select.value || null;
      this.#paint();
      this.host.chosen(this.chosen);
    };
    this.onClick = (/** @type {MouseEvent} */ e) => {
      const act = /** @type {HTMLElement} */ (e.target).closest('button')?.dataset.groupAct;
      const group = this.chosen;
      if (!group || !act) return;
      if (act === 'stop') this.host.stop(group.robots);
      else if (act === 'cancel') this.host.cancel(group.robots);
    };
    this.select.addEventListener('change', this.onChange);
    this.element.addEventListener('click', this.onClick);
  }

  /** @param {string} act @param {string} label */
  #button(act, label) {
    const b = document.createElement('button');
    b.type = 'button';
    b.dataset.groupAct = act;
    b.textContent = label;
    return b;
  }

  /** The chosen group as it is now (its robots where they stand), or null. */
  get chosen() {
    return this.groups.find((g) => g.id === this.chosenId) ?? null;
  }

  /** Whether the menu shows the row: there is a group to choose. */
  get visible() {
    return this.groups.length > 0;
  }

  /** Work the groups out again (at most every REFRESH_MS) and show what changed. @param {number} now page ms */
  update(now) {
    if (now - this.drawn < REFRESH_MS) return;
    this.drawn = now;
    this.groups = this.host.groups();
    const key = JSON.stringify([this.groups, this.chosenId, this.host.menu.role, this.host.menu.connected]);
    if (key === this.key) return;
    this.key = key;
    const chosen = this.chosen; // its robots as they are now
    if (this.chosenId !== null && !chosen) {
      this.chosenId = null; // a room the group's robots all left: nothing to command there now
      this.host.chosen(null);
    }
    const option = (/** @type {string} */ value, /** @type {string} */ text) => {
      const o = document.createElement('option');
      o.value = value;
      o.textContent = text;
      o.selected = value === (this.chosenId ?? '');
      return o;
    };
    this.select.replaceChildren(
      option('', 'Group…'),
      ...this.groups.map((g) => option(g.id, `${g.kind === 'team' ? 'Team' : 'Room'}: ${groupTitle(g)}`)),
    );
    this.#paint();
    if (chosen) this.host.chosen(chosen);
  }

  /** The buttons: for a chosen group, and what this page's role may do. */
  #paint() {
    const { role, connected } = this.host.menu;
    const group = this.chosen;
    this.stopButton.disabled = !group || !may(role, 'stop');
    this.cancelButton.disabled = !group || !connected || !may(role, 'drive');
    this.stopButton.textContent = group ? `Stop ${groupTitle(group)}` : 'Stop group';
  }

  dispose() {
    this.select.removeEventListener('change', this.onChange);
    this.element.removeEventListener('click', this.onClick);
  }
}
