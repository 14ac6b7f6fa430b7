// @ts-check
/**
 * The desktop page's geometry, without DOM: the part of the window no panel covers (where the 3D view centres
 * what the operator looks at and where framing fits the fleet), and the scale bar's length. Pure; node tests.
 */

/** @typedef {{left: number, top: number, right: number, bottom: number}} Rect */

/** Below this many CSS pixels wide or high, the page starts compact (menu collapsed, smaller panels). */
export const COMPACT_WIDTH = 1100;
export const COMPACT_HEIGHT = 700;

/** @param {{width: number, height: number}} viewport */
export function isCompact(viewport) {
  return viewport.width < COMPACT_WIDTH || viewport.height < COMPACT_HEIGHT;
}

/**
 * The largest rectangle of the viewport that no panel overlaps, with `gap` pixels of air beside each panel. Its
 * edges are the viewport's or a panel's (a handful of panels: every candidate is tried). Falls back to the whole
 * viewport when the panels leave less than a quarter of its width or height (nothing sensible fits there).
 * @param {{width: number, height: number}} viewport @param {Rect[]} panels @param {number} [gap]
 * @returns {Rect}
 */
export function freeRect(viewport, panels, gap = 8) {
  const { width, height } = viewport;
  const boxes = panels
    .filter((p) => p.right > p.left && p.bottom > p.top)
    .map((p) => ({ left: p.left - gap, top: p.top - gap, right: p.right + gap, bottom: p.bottom + gap }));
  const xs = [0, width, ...boxes.flatMap((b) => [b.left, b.right])].filter((x) => x >= 0 && x <= width);
  const ys = [0, height, ...boxes.flatMap((b) => [b.top, b.bottom])].filter((y) => y >= 0 && y <= height);
  /** @type {Rect} */
  let best = { left: 0, top: 0, right: width, bottom: height };
  let bestArea = -1;
  for (const left of xs) {
    for (const right of xs) {
      if (right - left < width / 4) continue;
      for (const top of ys) {
        for (const bottom of ys) {
          if (bottom - top < height / 4) continue;
          const area = (right - left) * (bottom - top);
          if (area <= bestArea) continue;
          if (boxes.some((b) => b.left < right && b.right > left && b.top < bottom && b.bottom > top)) continue;
          best = { left, top, right, bottom };
          bestArea = area;
        }
      }
    }
  }
  return best;
}

const NICE = [0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500];

/**
 * The scale bar: the longest round length (0.1 m ... 500 m) at most `maxPx` long, at `pxPerMetre`.
 * @param {number} pxPerMetre @param {number} [maxPx]
 * @returns {{metres: number, px: number, text: string}}
 */
export function scaleBar(pxPerMetre, maxPx = 120) {
  let metres = NICE[0];
  for (const m of NICE) if (m * pxPerMetre <= maxPx) metres = m;
  const text = metres < 1 ? `${Math.round(metres * 100)} cm` : `${metres} m`;
  return { metres, px: metres * pxPerMetre, text };
}
