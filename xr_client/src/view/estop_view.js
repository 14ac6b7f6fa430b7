// @ts-check
/**
 * The latched E-STOP where the operator cannot miss it, and the E-STOP always within reach in VR: a banner at the
 * top of the view (VR; the desktop's is HTML, in the overlay) that stays until the latch is reset, and an E-STOP
 * button under the wrist panel that the other hand's ray presses (it is the menu's `estop` button: the same rules,
 * the same refusals for viewers). What the banner says is estop_banner.js's (pure). The banner is an alarm: solid
 * red with white words, drawn over everything (the menu too), fixed in the view wherever the head turns.
 */
import { CanvasPlane } from './canvas_plane.js';
import { drawButtonFace, fillRounded, fitText, font } from './canvas_text.js';
import { CanvasSprite } from './label_sprite.js';

/** The banner's canvas, and its size and place in the view: 0.75 m wide at 0.9 m, about 45 x 9 degrees (its first
 * line's letters 2.5 degrees tall), from 8.5 to 17.5 degrees over the view's centre (a Quest 3 shows about 48 up):
 * read without looking up, and clear of the menu opened in front of the eyes (its top edge is 7.5 degrees up,
 * xr_interaction.js's placeMenu). It was a 0.11 m grey card with a red bar: easy to miss. */
const BANNER_PX = [1024, 200];
const BANNER_HEIGHT_M = 0.146;
const BANNER_AT = /** @type {[number, number, number]} */ ([0, 0.208, -0.9]);
/** The alarm's red (the menu's E-STOP red), and a lighter edge that sets it off from a red-lit twin. */
export const ALARM_RED = '#d31f1f';

export class EstopView {
  /** @param {import('three').Camera} camera the banner hangs from it */
  constructor(camera) {
    this.banner = new AlarmBanner();
    this.banner.sprite.position.set(...BANNER_AT);
    this.banner.sprite.visible = false;
    camera.add(this.banner.sprite);
    this.button = new CanvasPlane([256, 96], [0.09, 0.034], 'wrist-estop');
    this.button.mesh.userData.menuButton = 'estop';
    this.button.mesh.position.set(0, -0.06, 0.004);
    this.#drawButton(false);
    /** @type {import('../estop_banner.js').EstopBanner | null} */
    this.shown = null;
  }

  /** @param {import('../estop_banner.js').EstopBanner | null} banner @param {boolean} presenting */
  show(banner, presenting) {
    this.shown = banner;
    if (banner) this.banner.set(banner.text, banner.hint);
    this.banner.sprite.visible = banner !== null && presenting;
  }

  /** Carry the wrist button on the wrist panel (the left hand). @param {import('three').Object3D} wrist */
  attach(wrist) {
    if (this.button.mesh.parent !== wrist) wrist.add(this.button.mesh);
  }

  /** @param {boolean} hovered */
  hover(hovered) {
    if (hovered !== this.hovered) this.#drawButton(hovered);
  }

  /** @type {boolean | undefined} */
  hovered;

  /** @param {boolean} hovered */
  #drawButton(hovered) {
    this.hovered = hovered;
    drawButtonFace(this.button.canvas, 'E-STOP', hovered ? '#ff4d4d' : '#d31f1f', 22, 46, 800);
    this.button.texture.needsUpdate = true;
  }

  dispose() {
    this.banner.sprite.removeFromParent();
    this.banner.dispose();
    this.button.mesh.removeFromParent();
    this.button.dispose();
  }
}

/** The latched E-STOP as an alarm in the view: a solid red card with a white edge, a warning sign and white words. */
class AlarmBanner extends CanvasSprite {
  constructor() {
    super(BANNER_PX[0], BANNER_PX[1], true);
    this.sprite.name = 'estop-banner';
    this.scaleTo(BANNER_HEIGHT_M);
    this.sprite.renderOrder = 60; // over the menu (30) and the labels
    this.sprite.raycast = () => {}; // read, not pointed at: a ray passes to what is behind it
    this.key = '';
  }

  /** @param {string} text what is stopped, and by whom @param {string} hint what releases it */
  set(text, hint) {
    const key = `${text}|${hint}`;
    if (key === this.key) return;
    this.key = key;
    const [w, h] = BANNER_PX;
    const ctx = /** @type {CanvasRenderingContext2D} */ (this.canvas.getContext('2d'));
    ctx.clearRect(0, 0, w, h);
    fillRounded(ctx, [0, 0, w, h], 30, '#ffffff');
    fillRounded(ctx, [8, 8, w - 16, h - 16], 24, ALARM_RED);
    // A white warning sign with a red mark, on the left.
    const cx = 92;
    const cy = h / 2;
    ctx.beginPath();
    ctx.moveTo(cx, cy - 58);
    ctx.lineTo(cx + 64, cy + 52);
    ctx.lineTo(cx - 64, cy + 52);
    ctx.closePath();
    ctx.fillStyle = '#ffffff';
    ctx.fill();
    ctx.fillStyle = ALARM_RED;
    ctx.font = font(74, 800);
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    ctx.fillText('!', cx, cy + 12);
    ctx.textAlign = 'left';
    ctx.fillStyle = '#ffffff';
    fitText(ctx, text, 180, 76, w - 210, 56, 800);
    ctx.fillStyle = '#ffe3e3';
    fitText(ctx, hint, 180, 146, w - 210, 34, 600);
    this.texture.needsUpdate = true;
  }
}
