// @ts-check
/**
 * Where things sit on the VR finding card's canvas, in pixels (y down), and what a ray's hit on it means: the
 * capture's image on the left (fitted, its aspect kept, so a hit maps back to the capture's own pixels), the
 * buttons on the right, the reading's trend between the buttons and Close. Pure: view/finding_card.js draws these
 * rectangles and test/inspection_review.test.js pins the mapping both ways.
 */

/** The card's canvas, pixels; the plane is 0.64 m wide (the menu's width). */
export const CARD_PX = /** @type {[number, number]} */ ([1024, 640]);
const MARGIN = 24;
const HEADER = 64;
const IMAGE_BOX = { x: MARGIN, y: HEADER, w: 600, h: CARD_PX[1] - HEADER - MARGIN };
const COLUMN_X = IMAGE_BOX.x + IMAGE_BOX.w + MARGIN;
const COLUMN_W = CARD_PX[0] - COLUMN_X - MARGIN;

/**
 * @typedef {{id: string, label: string, x: number, y: number, w: number, h: number, active: boolean,
 *   enabled: boolean}} CardButton
 */
/** @typedef {{x: number, y: number, w: number, h: number}} Rect */

/**
 * The card for one finding.
 * @param {{status: string, proposal: boolean, imageAction: 'region' | 'target', operator: boolean,
 *   imageSize: [number, number] | null, before?: 'before' | 'after' | null, note?: boolean,
 *   dictation?: 'none' | 'ready' | 'listening'}} state what the buttons show, the capture's size once it is known,
 *   for a changed finding which of its images shows (null: it has one), whether the note is read in the image's
 *   place (a note of 1000 characters is 20 lines), and whether this browser takes a dictated note
 * @returns {{image: Rect | null, note: Rect | null, text: Rect, trend: Rect, buttons: CardButton[]}}
 */
export function cardLayout(state) {
  // Four rows of buttons above the trend (status twice, the image's or the note's actions, what the card shows) and
  // Close under it: 50 px rows (3.1 cm on the 0.4 m card, 2.2 degrees at its 0.8 m) leave the trend 100 px.
  const gap = 10;
  const h = 50;
  /** @type {CardButton[]} */
  const buttons = [];
  let y = HEADER + 150;
  const row = (/** @type {[string, string, boolean, boolean][]} */ items) => {
    const w = (COLUMN_W - gap * (items.length - 1)) / items.length;
    items.forEach(([id, label, active, enabled], i) =>
      buttons.push({ id, label, x: COLUMN_X + i * (w + gap), y, w, h, active, enabled }),
    );
    y += h + gap;
  };
  const op = state.operator;
  row([
    ['status:anomaly', 'Anomaly', state.status === 'anomaly', op],
    ['status:needs_review', 'Review', state.status === 'needs_review', op],
    ['status:ok', 'OK', state.status === 'ok', op],
  ]);
  // A second row: three buttons of a third of the column each are as narrow as a ray can still hit at arm's length.
  row([
    ['status:changed', 'Changed', state.status === 'changed', op],
    ['status:false_alarm', 'False alarm', state.status === 'false_alarm', op],
  ]);
  const note = state.note === true;
  if (note) {
    // The note read in the image's place: what acts on the image gives way to what writes the note.
    const listening = state.dictation === 'listening';
    row([
      ['note:dictate', listening ? 'Listening…' : 'Dictate', listening, op && state.dictation === 'ready'],
      ['note:clear', 'Clear note', false, op],
    ]);
  } else if (state.proposal) {
    row([
      ['region:accept', 'Accept region', false, op],
      ['region:redo', 'Redo', false, op],
    ]);
  } else {
    row([
      ['image:region', 'Mark region', state.imageAction === 'region', op],
      ['image:target', 'New target', state.imageAction === 'target', op],
    ]);
  }
  // What the left of the card shows: a changed finding's two images (the desktop's slider) or the image, and the
  // note; for everyone, viewers too (it only shows).
  const view = /** @type {[string, string, boolean, boolean][]} */ (
    state.before
      ? [
          ['card:after', 'After', !note && state.before === 'after', true],
          ['card:before', 'Before', !note && state.before === 'before', true],
        ]
      : [['card:image', 'Image', !note, true]]
  );
  row([...view, ['card:note', 'Note', note, true]]);
  // The trend: what is left of the column between the last row and Close (no button: a ray passes through it).
  const trend = { x: COLUMN_X, y, w: COLUMN_W, h: CARD_PX[1] - MARGIN - h - gap - y };
  y = CARD_PX[1] - MARGIN - h;
  row([['card:close', 'Close', false, true]]);
  return {
    image: state.imageSize && !note ? fitImage(state.imageSize) : null,
    note: note ? { ...IMAGE_BOX } : null,
    text: { x: COLUMN_X, y: HEADER, w: COLUMN_W, h: 140 },
    trend,
    buttons,
  };
}

/** The image's rectangle inside its box, its aspect kept and centred. @param {[number, number]} size */
function fitImage([w, h]) {
  const scale = Math.min(IMAGE_BOX.w / w, IMAGE_BOX.h / h);
  const fw = w * scale;
  const fh = h * scale;
  return { x: IMAGE_BOX.x + (IMAGE_BOX.w - fw) / 2, y: IMAGE_BOX.y + (IMAGE_BOX.h - fh) / 2, w: fw, h: fh };
}

/**
 * What a point of the card means: an enabled button, a pixel of the capture (u, v in its own pixels), or
 * nothing (the card's background, a disabled button).
 * @param {ReturnType<typeof cardLayout>} layout @param {[number, number] | null} imageSize
 * @param {number} px @param {number} py canvas pixels
 * @returns {{button: string} | {pixel: [number, number]} | null}
 */
export function cardHit(layout, imageSize, px, py) {
  for (const b of layout.buttons)
    if (px >= b.x && px <= b.x + b.w && py >= b.y && py <= b.y + b.h) return b.enabled ? { button: b.id } : null;
  const r = layout.image;
  if (r && imageSize && px >= r.x && px <= r.x + r.w && py >= r.y && py <= r.y + r.h) {
    return { pixel: [((px - r.x) / r.w) * imageSize[0], ((py - r.y) / r.h) * imageSize[1]] };
  }
  return null;
}

/**
 * The canvas point of a capture's pixel (the outline is drawn there; tests aim at it).
 * @param {Rect} image the image's rectangle on the card @param {[number, number]} imageSize @param {number} u
 * @param {number} v
 * @returns {[number, number]}
 */
export function pixelToCard(image, imageSize, u, v) {
  return [image.x + (u / imageSize[0]) * image.w, image.y + (v / imageSize[1]) * image.h];
}
