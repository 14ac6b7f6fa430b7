// @ts-check
/** Small drawing helpers shared by the canvas-textured panels (menu, wrist panel, labels). */

export const FONT_FAMILY = 'Inter, system-ui, sans-serif';

/** @param {number} px @param {number} [weight] */
export function font(px, weight = 500) {
  return `${weight} ${px}px ${FONT_FAMILY}`;
}

/**
 * @param {CanvasRenderingContext2D} ctx @param {number} x @param {number} y @param {number} w @param {number} h
 * @param {number} r
 */
export function roundRect(ctx, x, y, w, h, r) {
  ctx.beginPath();
  ctx.roundRect(x, y, w, h, r);
}

/**
 * A filled rounded rectangle (a panel's background, a button).
 * @param {CanvasRenderingContext2D} ctx @param {[number, number, number, number]} rect x, y, width, height
 * @param {number} radius @param {string} colour
 */
export function fillRounded(ctx, rect, radius, colour) {
  roundRect(ctx, rect[0], rect[1], rect[2], rect[3], radius);
  ctx.fillStyle = colour;
  ctx.fill();
}

/**
 * A button's face filling a canvas: a rounded colour and one centred word in white.
 * @param {HTMLCanvasElement} canvas @param {string} word @param {string} colour @param {number} radius
 * @param {number} px @param {number} weight
 */
export function drawButtonFace(canvas, word, colour, radius, px, weight) {
  const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
  const { width, height } = canvas;
  ctx.clearRect(0, 0, width, height);
  fillRounded(ctx, [2, 2, width - 4, height - 4], radius, colour);
  ctx.fillStyle = '#fff';
  ctx.textAlign = 'center';
  ctx.textBaseline = 'middle';
  ctx.font = font(px, weight);
  ctx.fillText(word, width / 2, height / 2 + 2);
}

/**
 * Text shrunk to fit a width.
 * @param {CanvasRenderingContext2D} ctx @param {string} text @param {number} x @param {number} y
 * @param {number} maxWidth @param {number} px @param {number} [weight]
 */
export function fitText(ctx, text, x, y, maxWidth, px, weight = 500) {
  let size = px;
  ctx.font = font(size, weight);
  while (size > 10 && ctx.measureText(text).width > maxWidth) {
    size -= 1;
    ctx.font = font(size, weight);
  }
  ctx.fillText(text, x, y);
}

/**
 * A warning triangle with an exclamation mark, centred at (cx, cy).
 * @param {CanvasRenderingContext2D} ctx @param {number} cx @param {number} cy @param {number} size
 */
export function warningIcon(ctx, cx, cy, size) {
  const h = size * 0.9;
  ctx.beginPath();
  ctx.moveTo(cx, cy - h / 2);
  ctx.lineTo(cx + size / 2, cy + h / 2);
  ctx.lineTo(cx - size / 2, cy + h / 2);
  ctx.closePath();
  ctx.fillStyle = '#e02424';
  ctx.fill();
  ctx.lineWidth = size * 0.06;
  ctx.strokeStyle = '#fff';
  ctx.stroke();
  ctx.fillStyle = '#fff';
  ctx.font = font(size * 0.55, 800);
  ctx.textAlign = 'center';
  ctx.textBaseline = 'middle';
  ctx.fillText('!', cx, cy + h * 0.12);
}

/**
 * A text broken into lines at spaces (a word longer than a line is cut) that fit ``maxWidth`` in the context's
 * current font; at most ``maxLines``, the last ending in an ellipsis when the text goes on.
 * @param {{measureText(text: string): {width: number}}} ctx @param {string} text @param {number} maxWidth
 * @param {number} maxLines
 * @returns {string[]}
 */
export function wrapLines(ctx, text, maxWidth, maxLines) {
  const fits = (/** @type {string} */ s) => ctx.measureText(s).width <= maxWidth;
  /** @type {string[]} */
  const lines = [];
  let line = '';
  for (const word of text.split(/\s+/).filter(Boolean)) {
    let rest = word;
    while (rest) {
      const joined = line ? `${line} ${rest}` : rest;
      if (fits(joined)) {
        [line, rest] = [joined, ''];
      } else if (line) {
        [lines[lines.length], line] = [line, ''];
      } else {
        let n = rest.length - 1; // a word wider than the line: as much of it as fits
        while (n > 1 && !fits(rest.slice(0, n))) n--;
        [lines[lines.length], rest] = [rest.slice(0, n), rest.slice(n)];
      }
    }
  }
  if (line) lines.push(line);
  if (lines.length <= maxLines) return lines;
  const kept = lines.slice(0, maxLines);
  let last = kept[maxLines - 1];
  while (last && !fits(`${last}…`)) last = last.slice(0, -1);
  kept[maxLines - 1] = `${last}…`;
  return kept;
}
