// @ts-check
/**
 * Where each menu button sits on the VR panel's canvas, in pixels (y down). Pure: the panel draws these
 * rectangles and maps a ray's hit point back to a button with `buttonAt`; tests check both.
 */

/** Row order and titles of the button groups. */
export const MENU_ROWS = Object.freeze([
  ['question', 'Study'],
  ['question2', ''],
  ['answers', 'Answer'],
  ['answering', ''],
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
 * The narrowest a button is drawn (canvas pixels): "robot100" or "Close" in 26 px letters, and a target a ray held
 * by a hand, or a glance, can rest on. A row whose buttons would be narrower wraps onto more lines: an Options row
 * of eight buttons left Close 96 pixels wide and the gaze-pinch and wrist E-STOP VR tests missed it every time.
 */
export const MIN_BUTTON_W = 110;

/** E-STOP is twice as wide as anything beside it: the easiest target on the panel. The robots' page label too. */
const weight = (/** @type {import('./menu_state.js').MenuButton} */ b) =>
  b.id === 'estop' || b.id === 'robots:page' ? 2 : 1;

/**
 * A row's buttons in as few lines as keep each at least MIN_BUTTON_W wide, shared out evenly (8 as 4 and 4, not 7
 * and 1), with the width of a weight-1 button on them: every line of a row on the same grid.
 * @param {import('./menu_state.js').MenuButton[]} inRow @param {number} usable @param {number} gap
 * @returns {{lines: import('./menu_state.js').MenuButton[][], unit: number}}
 */
function wrapRow(inRow, usable, gap) {
  const unitOf = (/** @type {import('./menu_state.js').MenuButton[]} */ line) =>
    (usable - gap * (line.length - 1)) / line.map(weight).reduce((a, b) => a + b, 0);
  for (let n = 1; ; n++) {
    const size = Math.ceil(inRow.length / n);
    const lines = Array.from({ length: Math.ceil(inRow.length / size) }, (_, i) =>
      inRow.slice(i * size, (i + 1) * size),
    );
    const unit = Math.min(...lines.map(unitOf));
    if (unit >= MIN_BUTTON_W || size === 1) return { lines, unit };
  }
}

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
  const rows = MENU_ROWS.filter(([group]) => buttons.some((b) => b.group === group)).map(([group]) => {
    const inRow = buttons.filter((b) => b.group === group);
    const left = group === 'estop' ? margin : margin + label;
    return { left, ...wrapRow(inRow, width - margin - left, gap) };
  });
  const count = rows.reduce((n, row) => n + row.lines.length, 0);
  const lineHeight = (height - header - margin - gap * (count - 1)) / count;
  /** @type {ButtonRect[]} */
  const rects = [];
  let y = header;
  for (const { left, lines, unit } of rows) {
    for (const line of lines) {
      let x = left;
      for (const b of line) {
        const w = unit * weight(b);
        rects.push({ id: b.id, x, y, w, h: lineHeight });
        x += w + gap;
      }
      y += lineHeight + gap;
    }
  }
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
