// @ts-check
/**
 * A text label as a sprite on a canvas texture. The canvas is redrawn only when the text changes (never
 * per frame), and the texture is reused.
 */
import { LINE_FONT, NAME_FONT } from '../label_rule.js';
import * as THREE from 'three';
import { fitText, font, roundRect, warningIcon } from './canvas_text.js';

/**
 * A canvas drawn as a sprite: its texture (sRGB, no mipmaps: redrawn text stays sharp) and material.
 * ``onTop``: drawn over everything (no depth test), as alarms and toasts are.
 */
export class CanvasSprite {
  /** @param {number} width @param {number} height canvas pixels @param {boolean} [onTop] */
  constructor(width, height, onTop = false) {
    this.canvas = document.createElement('canvas');
    this.canvas.width = width;
    this.canvas.height = height;
    this.texture = new THREE.CanvasTexture(this.canvas);
    this.texture.colorSpace = THREE.SRGBColorSpace;
    this.texture.generateMipmaps = false;
    this.texture.minFilter = THREE.LinearFilter;
    this.material = new THREE.SpriteMaterial({
      map: this.texture,
      transparent: true,
      depthTest: !onTop,
      depthWrite: false,
    });
    this.sprite = new THREE.Sprite(this.material);
  }

  /** Its size in the world: ``height`` metres tall, as wide as the canvas's proportions. @param {number} height */
  scaleTo(height) {
    this.sprite.scale.set((height * this.canvas.width) / this.canvas.height, height, 1);
  }

  dispose() {
    this.texture.dispose();
    this.material.dispose();
  }
}

export class LabelSprite extends CanvasSprite {
  /** @param {{width?: number, height?: number, worldHeight?: number, onTop?: boolean}} [options] */
  constructor(options = {}) {
    super(options.width ?? 512, options.height ?? 128, options.onTop);
    this.scaleTo(options.worldHeight ?? 0.22);
    if (options.onTop) this.sprite.renderOrder = 10;
    this.key = '';
  }

  /**
   * @param {string[]} lines first line bold
   * @param {LabelStyle} [style]
   */
  set(lines, style = {}) {
    const key = JSON.stringify([lines, style]);
    if (key === this.key) return;
    this.key = key;
    const ctx = /** @type {CanvasRenderingContext2D} */ (this.canvas.getContext('2d'));
    const { width, height } = this.canvas;
    ctx.clearRect(0, 0, width, height);
    drawLabel(ctx, 0, 0, width, height, lines, style);
    this.texture.needsUpdate = true;
  }
}

/**
 * A label's card: a rounded dark box, the accent bar, the lines (the first bold), in a rectangle of a canvas.
 * Sizes are those of a 150 px high label, scaled to the rectangle's height.
 * @param {CanvasRenderingContext2D} ctx @param {number} x @param {number} y @param {number} width
 * @param {number} height
 * @param {string[]} lines @param {LabelStyle} style
 */
export function drawLabel(ctx, x, y, width, height, lines, style) {
  const k = height / 150;
  roundRect(ctx, x + 4 * k, y + 4 * k, width - 8 * k, height - 8 * k, 18 * k);
  ctx.fillStyle = style.dim ? 'rgba(40,40,40,0.72)' : 'rgba(16,20,28,0.78)';
  ctx.fill();
  if (style.accent) {
    ctx.fillStyle = style.accent;
    ctx.fillRect(x + 4 * k, y + 18 * k, 10 * k, height - 36 * k);
  }
  ctx.textAlign = 'left';
  ctx.textBaseline = 'middle';
  const lineHeight = (height - 16 * k) / lines.length; // TEXT_SHARE of the height (label_rule.js)
  lines.forEach((line, i) => {
    ctx.fillStyle = style.dim ? '#aaa' : i === 0 ? '#fff' : '#c8d0dc';
    const px = lineHeight * (i === 0 ? NAME_FONT : LINE_FONT); // label_rule.js sizes labels by these
    fitText(ctx, line, x + 28 * k, y + 8 * k + lineHeight * (i + 0.5), width - 48 * k, px, i === 0 ? 700 : 500);
  });
}

/** @typedef {{accent?: string, dim?: boolean, warning?: boolean}} LabelStyle */

/** The red warning icon over a robot: drawn once, on top of everything, constant size on screen. */
export class WarningSprite {
  /** @param {THREE.SpriteMaterial} [shared] one material for every robot's icon (the fleet view's): no canvas each */
  constructor(shared) {
    this.shared = shared ?? null;
    this.material = shared ?? WarningSprite.material();
    this.sprite = new THREE.Sprite(this.material);
    this.sprite.scale.set(0.05, 0.05, 1);
    this.sprite.renderOrder = 20;
  }

  /** The icon's material (its own canvas texture), for one sprite or to share. */
  static material() {
    const canvas = document.createElement('canvas');
    canvas.width = canvas.height = 128;
    const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
    warningIcon(ctx, 64, 64, 112);
    ctx.font = font(10);
    const texture = new THREE.CanvasTexture(canvas);
    texture.colorSpace = THREE.SRGBColorSpace;
    // Visible from anywhere: no depth test, and a fixed angular size whatever the distance.
    return new THREE.SpriteMaterial({
      map: texture,
      depthTest: false,
      depthWrite: false,
      sizeAttenuation: false,
      transparent: true,
    });
  }

  /** Frees the material unless it is shared (its owner frees that). */
  dispose() {
    if (this.shared) return;
    this.material.map?.dispose();
    this.material.dispose();
  }
}

/** A message under the view in VR, for a few seconds (the desktop shows the overlay's message line instead). */
export class Toast {
  /** @param {THREE.Camera} camera what the toast hangs from @param {number} [seconds] how long it stays */
  constructor(camera, seconds = 5) {
    this.label = new LabelSprite({ width: 900, height: 120, worldHeight: 0.09, onTop: true });
    this.sprite = this.label.sprite;
    this.sprite.position.set(0, -0.18, -0.9);
    this.sprite.visible = false;
    camera.add(this.sprite);
    this.ms = seconds * 1000;
    this.until = 0;
  }

  /**
   * @param {string} text @param {'info' | 'error' | 'warning'} kind @param {boolean} presenting @param {number} now ms
   */
  say(text, kind, presenting, now) {
    this.label.set([text], { accent: kind === 'info' ? '#3d8bff' : kind === 'warning' ? '#ffb020' : '#e02424' });
    this.sprite.visible = presenting;
    this.until = now + this.ms;
  }

  /** Hide it once its time is up, or at once outside VR. @param {number} now ms @param {boolean} presenting */
  update(now, presenting) {
    if (this.sprite.visible && (!presenting || now > this.until)) this.sprite.visible = false;
  }

  dispose() {
    this.sprite.removeFromParent();
    this.label.dispose();
  }
}
