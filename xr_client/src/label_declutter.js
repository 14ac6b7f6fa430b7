// @ts-check
/**
 * Labels that would cover each other on the screen: the more important one is drawn, the other faded to a ghost
 * (it is still there to be picked, and it comes back as soon as it is clear). Important first: the selected robot's
 * and a warning's, then the nearest. With 20 robots at 1280 x 800, labels legible at 12 px (label_rule.js) are
 * 160-240 px wide: in the corridor half of them covered the other half. Pure: test/label_declutter.test.js.
 */

/** The opacity (a factor of the label's own) of a label another covers. */
export const COVERED_OPACITY = 0.18;
/** A label is covered when a more important one overlaps this share of its area. */
export const COVERED_SHARE = 0.3;

/**
 * @param {ArrayLike<number>} rects 4 numbers a label: x0, y0, x1, y1 on the screen (px); NaN x0: not drawn
 * @param {number[]} order the labels' indices, the most important first
 * @param {Float32Array} out each label's opacity factor: 1, or COVERED_OPACITY
 */
export function declutter(rects, order, out) {
  /** @type {number[]} */
  const shown = [];
  for (const i of order) {
    const [x0, y0, x1, y1] = [rects[4 * i], rects[4 * i + 1], rects[4 * i + 2], rects[4 * i + 3]];
    out[i] = 1;
    if (Number.isNaN(x0)) continue;
    const area = Math.max(1e-9, (x1 - x0) * (y1 - y0));
    const covered = shown.some((j) => {
      const w = Math.min(x1, rects[4 * j + 2]) - Math.max(x0, rects[4 * j]);
      const h = Math.min(y1, rects[4 * j + 3]) - Math.max(y0, rects[4 * j + 1]);
      return w > 0 && h > 0 && w * h > COVERED_SHARE * area;
    });
    if (covered) out[i] = COVERED_OPACITY;
    else shown.push(i);
  }
}
