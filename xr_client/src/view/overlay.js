// @ts-check
/**
 * The desktop overlay (HTML): the connection status, E-STOP and the latched-estop banner, the Enter VR button or why VR
 * is unavailable, the same menu as the VR panel (rendered from MenuState.buttons()), the sensor panel in a corner, the
 * Robot POV panel and a message line. Reads what its host gives it; clicks go back through the host's actions.
 */
import { QUESTION_GROUPS } from '../menu_buttons.js';
import { drawSensorPanel } from './sensor_drawing.js';
import { PagePanels } from './page_panels.js';
import { RobotPicker } from './robot_picker.js';
import { GroupBar } from './group_bar.js';
import { ROBOTS_PER_PAGE } from '../robot_pages.js';

/** @param {string} id */
function el(id) {
  const element = document.getElementById(id);
  if (!element) throw new Error(`index.html has no #${id}`);
  return element;
}

/** The VR notice the operator closed, for this tab (sessionStorage): shown again only for another reason. */
const VR_NOTICE_KEY = 'xr-relay.vr-notice-closed';

/** @param {string} key */
function readSession(key) {
  try {
    return window.sessionStorage.getItem(key);
  } catch {
    return null; // storage refused (a sandboxed frame): the notice shows, as it did before
  }
}

/** @param {string} key @param {string} value */
function writeSession(key, value) {
  try {
    window.sessionStorage.setItem(key, value);
  } catch {
    // Not remembered: closed for this page only.
  }
}

export class Overlay {
  /**
   * @param {{menu: import('../menu_state.js').MenuState, actions: import('../app.js').OperatorActions,
   *   sensorPanelData: (now: number) => import('./sensor_drawing.js').SensorPanelData, povText: () => string,
   *   robotFacts: () => import('../robot_picker.js').RobotFacts[],
   *   groups: ConstructorParameters<typeof GroupBar>[0]}} host what the page shows, and the group row's own host
   */
  constructor(host) {
    this.host = host;
    this.status = el('link-status');
    this.menu = el('menu');
    this.message = el('message');
    this.vrButton = /** @type {HTMLButtonElement} */ (el('enter-vr'));
    this.vrNotice = el('vr-notice');
    this.povPanel = el('pov-panel');
    this.povInfo = el('pov-info');
    this.sensorCanvas = /** @type {HTMLCanvasElement} */ (el('sensor-canvas'));
    this.estopBanner = el('estop-banner');
    /** The menu's robot row in a fleet larger than a row of buttons (view/robot_picker.js). */
    this.picker = new RobotPicker({ menu: host.menu, actions: host.actions, facts: host.robotFacts });
    /** The menu's row for groups of robots (view/group_bar.js), under the robots. */
    this.groupBar = new GroupBar(host.groups);
    /** Which panels are open (menu, sensors, help), compact in small windows. */
    this.panels = new PagePanels(window.localStorage, { width: window.innerWidth, height: window.innerHeight });
    /**
     * The latched-estop banner shown now (estop_banner.js), or null.
     * @type {import('../estop_banner.js').EstopBanner | null}
     */
    this.banner = null;
    this.bannerKey = '';
    this.menuKey = '';
    /** What the menu's buttons were drawn from. */
    this.drawnMenu = '';
    /** The menu's rows and buttons as last drawn, kept across drawings. @type {Map<string, HTMLElement>} */
    this.menuRows = new Map();
    /** @type {Map<string, HTMLButtonElement>} */
    this.menuButtons = new Map();
    this.messageTimer = /** @type {ReturnType<typeof setTimeout> | undefined} */ (undefined);
    this.sensorKey = '';
    this.lastSensorDraw = 0;
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const onMenuClick = (/** @type {MouseEvent} */ e) => {
      const button = /** @type {HTMLElement | null} */ (
        /** @type {HTMLElement} */ (e.target).closest('button[data-button]')
      );
      if (button && !(/** @type {HTMLButtonElement} */ (button).disabled))
        host.actions.pressMenu(/** @type {string} */ (button.dataset.button));
    };
    this.menu.addEventListener('click', onMenuClick);
    this.unlisten.push(() => this.menu.removeEventListener('click', onMenuClick));
    const onBanner = (/** @type {MouseEvent} */ e) => {
      if (/** @type {HTMLElement} */ (e.target).closest('button[data-button]')) onMenuClick(e);
    };
    this.estopBanner.addEventListener('click', onBanner);
    this.unlisten.push(() => this.estopBanner.removeEventListener('click', onBanner));
    const onVr = () => host.actions.enterVR();
    this.vrButton.addEventListener('click', onVr);
    this.unlisten.push(() => this.vrButton.removeEventListener('click', onVr));
  }

  /** @param {string} text @param {boolean} ok */
  setLink(text, ok) {
    this.status.textContent = text;
    this.status.className = `status ${ok ? 'ok' : 'bad'}`;
  }

  /**
   * Enter VR, or why not. The reason can be closed (×): an operator on a desktop without a headset has read it once
   * and needs the header's room back; it stays closed for the tab until the reason changes.
   * @param {{available: boolean, reason: string, fix: string}} availability
   */
  setVr(availability) {
    this.vrButton.hidden = !availability.available;
    const dismissed = readSession(VR_NOTICE_KEY) === availability.reason;
    this.vrNotice.hidden = availability.available || !availability.reason || dismissed;
    this.vrNotice.replaceChildren();
    if (!availability.available && availability.reason) {
      const reason = document.createElement('strong');
      reason.textContent = availability.reason;
      const fix = document.createElement('span');
      fix.textContent = ` ${availability.fix}`;
      const close = document.createElement('button');
      close.type = 'button';
      close.className = 'close';
      close.textContent = '×';
      close.title = 'Close this notice';
      close.setAttribute('aria-label', 'Close this notice');
      close.addEventListener(
        'click',
        () => {
          this.vrNotice.hidden = true;
          writeSession(VR_NOTICE_KEY, availability.reason);
        },
        { once: true },
      );
      this.vrNotice.append(reason, fix, close);
    }
  }

  /**
   * The latched estop, at the top of the page until it is reset (null: none), with Reset E-STOP for operators.
   * @param {import('../estop_banner.js').EstopBanner | null} banner
   */
  setBanner(banner) {
    this.banner = banner;
    const reset = this.host.menu.buttons().find((b) => b.id === 'estop:reset');
    // Every status brings the latch again: the banner is rebuilt only when what it says changed.
    const key = banner ? `${banner.text}|${banner.hint}|${reset?.enabled}` : '';
    if (key === this.bannerKey) return;
    this.bannerKey = key;
    this.estopBanner.hidden = banner === null;
    this.estopBanner.dataset.fleet = String(banner?.fleet ?? false);
    this.estopBanner.replaceChildren();
    if (!banner) return;
    const text = document.createElement('strong');
    text.textContent = banner.text;
    const hint = document.createElement('span');
    hint.textContent = banner.hint;
    this.estopBanner.append(text, hint);
    if (reset?.enabled) {
      const button = document.createElement('button');
      button.type = 'button';
      button.dataset.button = 'estop:reset';
      button.textContent = 'Reset E-STOP';
      this.estopBanner.append(button);
    }
  }

  /** @param {string} text @param {'info' | 'error' | 'warning'} [kind] @param {number} [ms] */
  say(text, kind = 'info', ms = 6000) {
    this.message.textContent = text;
    this.message.className = `message ${kind}`;
    clearTimeout(this.messageTimer);
    this.messageTimer = setTimeout(() => {
      this.message.textContent = '';
      this.message.className = 'message';
    }, ms);
  }

  /** Redraw what changed. @param {number} now */
  update(now) {
    const menu = this.host.menu;
    const key = String(menu.version);
    if (key !== this.menuKey) {
      this.menuKey = key;
      this.#drawMenu();
      this.povPanel.hidden = menu.mode !== 'pov';
    }
    const data = this.host.sensorPanelData(now);
    if (data.link !== this.status.textContent) this.setLink(data.link, data.linkOk);
    const sensorKey = `${data.robot}|${data.status}|${data.link}|${data.sensors.map((s) => s.warning).join()}`;
    // In VR the page's panels are hidden (style.css, body.presenting): the wrist panel shows the readings there.
    const hidden = document.body.classList.contains('presenting');
    if (hidden) this.sensorKey = '';
    else if (sensorKey !== this.sensorKey || now - this.lastSensorDraw > 250) {
      this.sensorKey = sensorKey;
      this.lastSensorDraw = now;
      const ctx = /** @type {CanvasRenderingContext2D} */ (this.sensorCanvas.getContext('2d'));
      drawSensorPanel(ctx, this.sensorCanvas.width, this.sensorCanvas.height, data);
      this.sensorCanvas.dataset.robot = data.robot ?? '';
      this.sensorCanvas.dataset.warning = String(data.sensors.some((s) => s.warning));
      this.sensorCanvas.dataset.latency = (data.latency ?? []).map((p) => p.text).join(' · ');
    }
    if (menu.mode === 'pov') this.povInfo.textContent = this.host.povText();
    if (menu.robots.length > ROBOTS_PER_PAGE && !hidden) this.picker.update(now);
    if (!hidden) {
      const shown = this.groupBar.visible;
      this.groupBar.update(now);
      if (shown !== this.groupBar.visible) this.#drawMenu();
    }
  }

  #drawMenu() {
    const groups = new Map();
    const picking = this.host.menu.robots.length > ROBOTS_PER_PAGE;
    const buttons = this.host.menu.buttons();
    // Most menu changes (a robot's status, a count elsewhere) leave its buttons as they were: they stay in the page,
    // not replaced under the mouse (a click, or a scroll to the menu's end, on a button just taken out).
    const drawn = `${picking}|${this.groupBar.visible}|${buttons
      .map((b) => `${b.group}:${b.id}:${b.label}:${b.enabled}:${b.active}:${Boolean(b.danger)}`)
      .join('|')}`;
    if (drawn === this.drawnMenu) return;
    this.drawnMenu = drawn;
    // The rest keep their elements too (a new alert row's buttons came while a test scrolled to the menu's last
    // button, and it was detached under it): each button and row is its element of the last drawing, updated.
    /** @type {Map<HTMLElement, HTMLElement[]>} */
    const contents = new Map();
    /** @type {Map<string, HTMLButtonElement>} */
    const kept = new Map();
    for (const button of buttons) {
      if (button.id === 'menu:close') continue; // the desktop menu is always open
      if (QUESTION_GROUPS.includes(button.group)) continue; // the page's study panel asks it
      if (picking && (button.group === 'robots' || button.group === 'pages')) {
        groups.set('robots', this.picker.element); // the picker lists every robot: no page of buttons
        if (this.groupBar.visible) groups.set('group', this.groupBar.element);
        continue;
      }
      let row = groups.get(button.group);
      if (!row) {
        row = this.menuRows.get(button.group) ?? document.createElement('div');
        row.className = `row ${button.group}`;
        this.menuRows.set(button.group, row);
        groups.set(button.group, row);
        contents.set(row, []);
        if (button.group === 'robots' && this.groupBar.visible) groups.set('group', this.groupBar.element);
      }
      const b = this.menuButtons.get(button.id) ?? document.createElement('button');
      b.type = 'button';
      b.dataset.button = button.id;
      if (b.textContent !== button.label) b.textContent = button.label;
      b.disabled = !button.enabled;
      b.setAttribute('aria-pressed', String(button.active));
      b.className = button.danger ? 'estop' : '';
      kept.set(button.id, b);
      contents.get(row)?.push(b);
    }
    this.menuButtons = kept;
    for (const [row, children] of contents) arrange(row, children);
    arrange(this.menu, [...groups.values()]);
  }

  /** The POV panel's rectangle in CSS pixels, for the scissored render. */
  povRect() {
    return this.povPanel.getBoundingClientRect();
  }

  dispose() {
    clearTimeout(this.messageTimer);
    this.panels.dispose();
    this.picker.dispose();
    this.groupBar.dispose();
    for (const off of this.unlisten) off();
  }
}

/**
 * `parent`'s children made `children`, in order, the ones already there never taken out: a focused search box taken
 * out of the page loses its focus (the robot picker's), a button taken out loses the click or scroll aimed at it.
 * @param {HTMLElement} parent @param {HTMLElement[]} children
 */
function arrange(parent, children) {
  for (const child of [...parent.children]) if (!children.includes(/** @type {HTMLElement} */ (child))) child.remove();
  /** @type {ChildNode | null} */
  let at = parent.firstChild;
  for (const child of children) {
    if (child !== at) parent.insertBefore(child, at);
    at = child.nextSibling;
  }
}
