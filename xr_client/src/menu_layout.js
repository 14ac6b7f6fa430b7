// @ts-check
/**
 * Where each menu button sits on the VR panel's canvas, in pixels (y down). Pure: the panel draws these
 * rectangles and maps a ray's hit point back to a button with `buttonAt`; tests check both.
 */

/** Row order and titles of the button groups. */
export const MENU_ROWS = Object.freeze([
  ['mode', 'View'],
  ['robots', 'Robot'],
  ['pages', ''],
  ['tools', 'Tool'],
  ['camera', 'Camera'],
  ['mission', 'Mission'],
  ['alerts', 'Alerts'],
  ['findings', 'Findings'],
  ['options', 'Options'],
  ['sound', 'Sound'],
  ['estop', ''],
]);

/** @typedef {{id: string, x: number, y: number, w: number, h: number}} ButtonRect */

/**
 * @param {import('./menu_state.js').MenuButton[]} buttons
 * @param {number} width @param {number} height canvas size
 * @param {{header?: number, margin?: number, gap?: number, label?: number}} [options]
 * @returns {ButtonRect[]}
 */
export function layoutMenu(buttons, width, height, options = {}) {
  const header = options.header ?? 70;
  const margin = options.margin ?? 24;
  const gap = options.gap ?? 12;
  const label = options.label ?? 120;
  const rows = MENU_ROWS.filter(([group]) => buttons.some((b) => b.group === group));
  const rowHeight = (height - header - margin - gap * (rows.length - 1)) / rows.length;
  /** @type {ButtonRect[]} */
  const rects = [];
  rows.forEach(([group], r) => {
    const inRow = buttons.filter((b) => b.group === group);
    const left = group === 'estop' ? margin : margin + label;
    const usable = width - margin - left;
    // E-STOP is twice as wide as anything beside it: the easiest target on the panel. The robots' page label too:
    // "robots 13-18 of 20" in the row's letters.
    const weights = inRow.map((b) => (b.id === 'estop' || b.id === 'robots:page' ? 2 : 1));
    const unit = (usable - gap * (inRow.length - 1)) / weights.reduce((a, b) => a + b, 0);
    const y = header + r * (rowHeight + gap);
    let x = left;
    inRow.forEach((b, i) => {
      rects.push({ id: b.id, x, y, w: unit * weights[i], h: rowHeight });
      x += unit * weights[i] + gap;
    });
  });
  return rects;
}

/**
 * The button under a canvas pixel, or null.
 * @param {ButtonRect[]} rects @param {number} px @param {number} py
 */
export function buttonAt(rects, px, py) {
  for (const r of rects) if (px >= r.x && px <= r.x + r.w && py >= r.y && py <= r.y + r.h) return r.id;
  return null;
}
