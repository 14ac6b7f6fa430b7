// @ts-check
/**
 * The latched E-STOP where the operator cannot miss it, and the E-STOP always within reach in VR: a banner at the
 * top of the view (VR; the desktop's is HTML, in the overlay) that stays until the latch is reset, and an E-STOP
 * button under the wrist panel that the other hand's ray presses (it is the menu's `estop` button: the same rules,
 * the same refusals for viewers). What the banner says is estop_banner.js's (pure).
 */
import { CanvasPlane } from './canvas_plane.js';
import { fillRounded, font } from './canvas_text.js';
import { LabelSprite } from './label_sprite.js';

export class EstopView {
  /** @param {import('three').Camera} camera the banner hangs from it */
  constructor(camera) {
    this.banner = new LabelSprite({ width: 1024, height: 150, worldHeight: 0.11, onTop: true });
    this.banner.sprite.position.set(0, 0.2, -0.9);
    this.banner.sprite.renderOrder = 12;
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
    if (banner) this.banner.set([banner.text, banner.hint], { accent: '#e02424' });
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
    const ctx = /** @type {CanvasRenderingContext2D} */ (this.button.canvas.getContext('2d'));
    ctx.clearRect(0, 0, 256, 96);
    fillRounded(ctx, [2, 2, 252, 92], 22, hovered ? '#ff4d4d' : '#d31f1f');
    ctx.fillStyle = '#fff';
    ctx.textAlign = 'center';
    ctx.textBaseline = 'middle';
    ctx.font = font(46, 800);
    ctx.fillText('E-STOP', 128, 50);
    this.button.texture.needsUpdate = true;
  }

  dispose() {
    this.banner.sprite.removeFromParent();
    this.banner.dispose();
    this.button.mesh.removeFromParent();
    this.button.dispose();
  }
}
