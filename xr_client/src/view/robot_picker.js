// @ts-check
/**
 * The desktop menu's robot row for a fleet larger than a row of buttons holds (20 robots' buttons shrank to `ro`):
 * the selected robot's name, which opens the list of every robot, and a search box that filters it by name. The list
 * gives each robot's status, battery, mission and open alerts (robot_picker.js words them), sorted by name or by
 * status; a click, or Enter on the entry found first, selects the robot as its button did. The keys stay the
 * page's: letters typed here fly nothing, Space and Esc are E-STOP (view/desktop_keys.js; a robot's name has no
 * spaces), Esc also closing the list. Listeners are added in the constructor and removed in dispose().
 */
import { pickerRows } from '../robot_picker.js';

/** How often an open list is rewritten while only statuses change (ms): often enough to read, not per frame. */
const REFRESH_MS = 500;

export class RobotPicker {
  /**
   * @param {{menu: import('../menu_state.js').MenuState, actions: import('../app.js').OperatorActions,
   *   facts: () => import('../robot_picker.js').RobotFacts[]}} host
   */
  constructor(host) {
    this.host = host;
    this.element = document.createElement('div');
    this.element.className = 'row robots picker';
    this.current = document.createElement('button');
    this.current.type = 'button';
    this.current.className = 'picker-current';
    this.current.setAttribute('aria-expanded', 'false');
    this.current.setAttribute('aria-controls', 'robot-list');
    this.search = document.createElement('input');
    this.search.type = 'text'; // not 'search': its Esc would clear what was typed and open the list again
    this.search.className = 'picker-search';
    this.search.setAttribute('role', 'searchbox');
    this.search.autocomplete = 'off';
    this.search.spellcheck = false;
    this.search.setAttribute('aria-label', 'Find a robot by name');
    this.list = document.createElement('div');
    this.list.className = 'picker-list';
    this.list.hidden = true;
    const sorts = document.createElement('div');
    sorts.className = 'picker-sort';
    sorts.append('Sort by');
    for (const [sort, label] of [
      ['name', 'name'],
      ['status', 'status'],
    ]) {
      const b = document.createElement('button');
      b.type = 'button';
      b.dataset.sort = sort;
      b.textContent = label;
      sorts.append(b);
    }
    this.entries = document.createElement('ul');
    this.entries.id = 'robot-list';
    this.entries.setAttribute('role', 'listbox');
    this.entries.setAttribute('aria-label', 'Robots');
    this.list.append(sorts, this.entries);
    this.element.append(this.current, this.search, this.list);
    /** @type {import('../robot_picker.js').PickerSort} */
    this.sort = 'name';
    /** The entry Enter picks (0: the best match). */
    this.active = 0;
    /** @type {import('../robot_picker.js').PickerRow[]} */
    this.rows = [];
    this.key = '';
    this.drawn = -Infinity;
    this.shownVersion = -1;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    this.#listen();
  }

  #listen() {
    const on = (/** @type {EventTarget} */ target, /** @type {string} */ type, /** @type {(e: any) => void} */ fn) => {
      target.addEventListener(type, fn);
      this.unlisten.push(() => target.removeEventListener(type, fn));
    };
    on(this.current, 'click', () => {
      this.setOpen(this.list.hidden);
      if (!this.list.hidden) this.search.focus();
    });
    on(this.search, 'focus', () => this.setOpen(true));
    on(this.search, 'click', () => this.setOpen(true));
    on(this.search, 'input', () => {
      this.active = 0;
      if (this.list.hidden) this.setOpen(true);
      else this.#draw();
    });
    on(this.search, 'keydown', (/** @type {KeyboardEvent} */ e) => this.#key(e));
    on(this.list, 'click', (/** @type {MouseEvent} */ e) => {
      const target = /** @type {HTMLElement} */ (e.target);
      const robot = /** @type {HTMLElement | null} */ (target.closest('button[data-robot]'));
      const sort = /** @type {HTMLElement | null} */ (target.closest('button[data-sort]'));
      if (robot?.dataset.robot) this.pick(robot.dataset.robot);
      else if (sort) {
        this.sort = sort.dataset.sort === 'status' ? 'status' : 'name';
        this.#activateSelected();
      }
    });
    // A press anywhere else on the page closes the list, as a click on the twin ends a search.
    on(document, 'pointerdown', (/** @type {PointerEvent} */ e) => {
      if (!this.element.contains(/** @type {Node} */ (e.target))) this.setOpen(false);
    });
  }

  /** Enter picks the active entry, the arrows move it; Esc closes the list (and, the page's key, stops the fleet). */
  #key(/** @type {KeyboardEvent} */ e) {
    if (e.key === 'Enter') {
      e.preventDefault();
      const row = this.rows[this.active];
      if (row) this.pick(row.name);
    } else if (e.key === 'ArrowDown' || e.key === 'ArrowUp') {
      e.preventDefault();
      this.setOpen(true);
      const step = e.key === 'ArrowDown' ? 1 : -1;
      this.#activate(Math.max(0, Math.min(this.rows.length - 1, this.active + step)));
    } else if (e.key === 'Escape') this.setOpen(false); // not stopped: desktop_keys.js hears it too (E-STOP)
  }

  /** Select a robot, as its button did, and close the list. @param {string} name */
  pick(name) {
    this.host.actions.selectRobot(name);
    this.search.value = '';
    this.setOpen(false);
    this.search.blur(); // the keys go back to the page: WASD flies again
  }

  /** @param {boolean} open */
  setOpen(open) {
    if (open === !this.list.hidden) return;
    this.list.hidden = !open;
    this.current.setAttribute('aria-expanded', String(open));
    if (open) this.#activateSelected();
  }

  /** The list on the selected robot, unless a search is typed: Enter then picks what it found first. */
  #activateSelected() {
    this.active = 0;
    this.#draw();
    const at = this.search.value.trim() ? -1 : this.rows.findIndex((r) => r.name === this.host.menu.selected);
    this.#activate(Math.max(at, 0));
  }

  /** Mark an entry as the one Enter picks, in view. @param {number} index */
  #activate(index) {
    this.active = index;
    this.#draw();
    this.entries.children[index]?.scrollIntoView({ block: 'nearest' });
  }

  /** The selected robot's name, and the open list again when the statuses it shows changed. @param {number} now */
  update(now) {
    const menu = this.host.menu;
    if (menu.version !== this.shownVersion) {
      this.shownVersion = menu.version;
      this.current.textContent = `${menu.selected ?? 'No robot'} ▾`;
      this.current.dataset.selected = String(menu.selected !== null);
      this.current.title = `Choose among ${menu.robots.length} robots`;
      this.search.placeholder = 'Search…';
      this.search.title = `Find among ${menu.robots.length} robots by name`;
    }
    if (!this.list.hidden && now - this.drawn > REFRESH_MS) this.#draw(now);
  }

  /** Rewrite the list, only when what it shows changed. @param {number} [now] */
  #draw(now = performance.now()) {
    this.drawn = now;
    this.rows = pickerRows(this.host.facts(), this.search.value, this.sort);
    this.active = Math.min(this.active, Math.max(0, this.rows.length - 1));
    const selected = this.host.menu.selected;
    const key = JSON.stringify([this.rows, this.active, selected, this.sort]);
    if (key === this.key) return;
    this.key = key;
    for (const b of /** @type {NodeListOf<HTMLElement>} */ (this.list.querySelectorAll('button[data-sort]')))
      b.setAttribute('aria-pressed', String(b.dataset.sort === this.sort));
    this.entries.replaceChildren(
      ...this.rows.map((row, i) => {
        const item = document.createElement('li');
        const b = document.createElement('button');
        b.type = 'button';
        b.dataset.robot = row.name;
        b.dataset.rank = String(row.rank);
        b.setAttribute('role', 'option');
        b.setAttribute('aria-selected', String(row.name === selected));
        if (i === this.active) b.classList.add('active');
        const name = document.createElement('span');
        name.className = 'name';
        name.textContent = row.name;
        const status = document.createElement('span');
        status.className = 'state';
        status.textContent = row.status;
        b.append(name, status);
        if (row.details) {
          const details = document.createElement('span');
          details.className = 'details';
          details.textContent = row.details;
          b.append(details);
        }
        item.append(b);
        return item;
      }),
    );
    if (this.rows.length === 0) {
      const none = document.createElement('li');
      none.className = 'none';
      none.textContent = `No robot's name holds "${this.search.value.trim()}"`;
      this.entries.append(none);
    }
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}
