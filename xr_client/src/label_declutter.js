// @ts-check
/**
 * Labels that would cover each other on the screen: the more important one is drawn, the other faded to a ghost
 * (it is still there to be picked, and it comes back as soon as it is clear). Important first: the selected robot's
 * and a warning's, then the nearest. With 20 robots at 1280 x 800, labels legible at 12 px (label_rule.js) are
 * 160-240 px wide: in the corridor half of them covered the other half. The same on the desktop's page and in a
 * headset (there on the left eye's picture): each label's rectangle is its quad projected by the viewing camera
 * (labelRect). Pure, and nothing allocated per frame: test/label_declutter.test.js.
 */

/** The opacity (a factor of the label's own) of a label another covers. */
export const COVERED_OPACITY = 0.18;
/** A label is covered when a more important one overlaps this share of its area, or of the more important one's if
 * that is smaller: no label drawn hides more than this share of another, whichever of the two is drawn on top (a
 * label's size on the picture grows off the view's axis, so the nearer is not always the larger). */
export const COVERED_SHARE = 0.3;

/**
 * @param {ArrayLike<number>} rects 4 numbers a label: x0, y0, x1, y1 on the screen (px); NaN x0: not drawn
 * @param {number[]} order the labels' indices, the most important first
 * @param {Float32Array} out each label's opacity factor: 1, or COVERED_OPACITY
 */
export function declutter(rects, order, out) {
  // The labels already drawn are the earlier ones in `order` whose factor is 1: no list of them is kept (this runs
  // every frame, and a frame allocates nothing for its labels).
  for (let k = 0; k < order.length; k++) {
    const i = order[k];
    const x0 = rects[4 * i];
    const y0 = rects[4 * i + 1];
    const x1 = rects[4 * i + 2];
    const y1 = rects[4 * i + 3];
    out[i] = 1;
    if (Number.isNaN(x0)) continue;
    const area = (x1 - x0) * (y1 - y0);
    for (let m = 0; m < k; m++) {
      const j = order[m];
      if (out[j] !== 1 || Number.isNaN(rects[4 * j])) continue;
      const w = Math.min(x1, rects[4 * j + 2]) - Math.max(x0, rects[4 * j]);
      const h = Math.min(y1, rects[4 * j + 3]) - Math.max(y0, rects[4 * j + 1]);
      const other = (rects[4 * j + 2] - rects[4 * j]) * (rects[4 * j + 3] - rects[4 * j + 1]);
      if (w > 0 && h > 0 && w * h > COVERED_SHARE * Math.min(area, other)) {
        out[i] = COVERED_OPACITY;
        break;
      }
    }
  }
}

/**
 * A label's rectangle on a camera's picture: the label is a quad facing the camera (label_atlas.js draws it in
 * view space), so its rectangle is two opposite corners projected. The picture is `width` x `height`, y down (the
 * page's pixels on the desktop, the left eye's in a headset); an XR eye's frustum is asymmetric, so the whole
 * projection matrix is applied, not a field of view.
 * @param {ArrayLike<number>} projection the camera's projection matrix, column-major (three.js Matrix4.elements)
 * @param {number} left @param {number} bottom @param {number} right @param {number} top the quad in the camera's
 *   view space (m, y up)
 * @param {number} z its depth in view space (m, negative in front of the camera)
 * @param {number} width @param {number} height the picture's size
 * @param {Float32Array} rects where the rectangle goes (x0, y0, x1, y1, as declutter takes them)
 * @param {number} i the label's index: rects[4 * i] onwards; NaN x0 when the quad is behind the camera
 */
export function labelRect(projection, left, bottom, right, top, z, width, height, rects, i) {
  const e = projection;
  const w = e[11] * z + e[15]; // the same for every corner: they share their depth
  if (!(w > 0)) {
    rects[4 * i] = NaN;
    return;
  }
  // A perspective projection scales x and y and shifts them by depth (an eye's asymmetric frustum): no shear, so
  // two corners make the rectangle. Normalized device coordinates (-1..1, y up) become the picture's (y down).
  const x0 = (e[0] * left + e[8] * z + e[12]) / w;
  const x1 = (e[0] * right + e[8] * z + e[12]) / w;
  const y0 = (e[5] * bottom + e[9] * z + e[13]) / w;
  const y1 = (e[5] * top + e[9] * z + e[13]) / w;
  rects[4 * i] = ((x0 + 1) / 2) * width;
  rects[4 * i + 1] = ((1 - y1) / 2) * height;
  rects[4 * i + 2] = ((x1 + 1) / 2) * width;
  rects[4 * i + 3] = ((1 - y0) / 2) * height;
}
