// @ts-check
/**
 * The desktop page's panels open or collapsed: the menu (collapsed, it keeps its E-STOP row), the sensor panel
 * and the help box, each with a header button (and the help box its own close button and the ? key). Windows
 * under 1100 x 700 start compact (menu collapsed, no help; CSS makes the panels smaller there); what the operator
 * chooses is remembered in localStorage for the next visit. The 3D view re-centres on what the panels leave free
 * (view/desktop_views.js reads their rectangles).
 */
import { isCompact } from '../layout.js';
import { typingIn } from './typing.js';

const KEY = 'xr-relay.panels';
/** @typedef {{menu: boolean, sensors: boolean, help: boolean}} PanelsOpen */

export class PagePanels {
  /** @param {Storage | null} storage @param {{width: number, height: number}} viewport */
  constructor(storage, viewport) {
    this.storage = storage;
    const compact = isCompact(viewport);
    /** @type {PanelsOpen} */
    this.open = { menu: !compact, sensors: true, help: !compact };
    try {
      const saved = JSON.parse(storage?.getItem(KEY) ?? 'null');
      if (saved && typeof saved === 'object')
        for (const k of /** @type {(keyof PanelsOpen)[]} */ (['menu', 'sensors', 'help']))
          if (typeof saved[k] === 'boolean') this.open[k] = saved[k];
    } catch {
      // An unreadable saved layout is forgotten: the defaults stand.
    }
    document.body.classList.toggle('compact', compact);
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const onClick = (/** @type {MouseEvent} */ e) => {
      const button = /** @type {HTMLElement | null} */ (
        /** @type {HTMLElement} */ (e.target).closest('button[data-panel]')
      );
      if (button) this.toggle(/** @type {keyof PanelsOpen} */ (button.dataset.panel));
    };
    const onKey = (/** @type {KeyboardEvent} */ e) => {
      const target = /** @type {HTMLElement} */ (e.target);
      if (e.key === '?' && !typingIn(target)) this.toggle('help');
    };
    const onResize = () => {
      document.body.classList.toggle('compact', isCompact({ width: window.innerWidth, height: window.innerHeight }));
      this.#measure();
    };
    document.addEventListener('click', onClick);
    window.addEventListener('keydown', onKey);
    window.addEventListener('resize', onResize);
    this.unlisten.push(
      () => document.removeEventListener('click', onClick),
      () => window.removeEventListener('keydown', onKey),
      () => window.removeEventListener('resize', onResize),
    );
    this.#apply();
    onResize();
    this.resizeObserver = new ResizeObserver(onResize);
    for (const panel of [document.querySelector('header'), document.getElementById('help')])
      if (panel) this.resizeObserver.observe(panel);
  }

  /**
   * Panels hang below the header, however many lines it takes in a narrow window; the menu ends above the help box
   * while it is open, so the help never covers a menu button (the menu scrolls instead, its E-STOP row first).
   */
  #measure() {
    const style = document.documentElement.style;
    style.setProperty('--header', `${document.querySelector('header')?.offsetHeight ?? 44}px`);
    const help = this.open.help ? (document.getElementById('help')?.offsetHeight ?? 0) : 0;
    style.setProperty('--help', `${help > 0 ? help + 8 : 0}px`);
  }

  /** @param {keyof PanelsOpen} panel */
  toggle(panel) {
    if (!(panel in this.open)) return;
    this.open[panel] = !this.open[panel];
    this.storage?.setItem(KEY, JSON.stringify(this.open));
    this.#apply();
  }

  #apply() {
    const body = document.body.classList;
    body.toggle('menu-collapsed', !this.open.menu);
    body.toggle('sensors-hidden', !this.open.sensors);
    body.toggle('help-hidden', !this.open.help);
    for (const button of document.querySelectorAll('header button[data-panel]')) {
      const panel = /** @type {keyof PanelsOpen} */ (/** @type {HTMLElement} */ (button).dataset.panel);
      button.setAttribute('aria-pressed', String(this.open[panel]));
    }
    this.#measure();
  }

  dispose() {
    this.resizeObserver.disconnect();
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}
