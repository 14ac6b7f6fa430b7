// @ts-check
/**
 * The VR panels drawn on canvas textures: the floating menu (buttons from MenuState, hover highlight) and
 * the wrist sensor panel. Both redraw only when what they show changed, never per frame, and the menu only while open.
 */
import { panelButtons } from '../menu_buttons.js';
import * as THREE from 'three';
import { CanvasPlane } from './canvas_plane.js';
import { buttonAt, layoutMenu, MENU_ROWS } from '../menu_layout.js';
import { drawButtonFace, fillRounded, fitText, font, roundRect } from './canvas_text.js';
import { drawSensorPanel } from './sensor_drawing.js';

/** @type {[number, number]} */
const MENU_PX = [1024, 700];
/** @type {[number, number]} */
const MENU_M = [0.64, 0.4375];

export class MenuPanel {
  constructor() {
    this.plane = new CanvasPlane(MENU_PX, MENU_M, 'menu');
    this.canvas = this.plane.canvas;
    this.texture = this.plane.texture;
    this.texture.anisotropy = 4;
    this.mesh = this.plane.mesh;
    this.mesh.renderOrder = 30;
    this.mesh.visible = false;
    /** @type {import('../menu_layout.js').ButtonRect[]} */
    this.rects = [];
    /** @type {import('../menu_state.js').MenuButton[]} */
    this.buttons = [];
    this.key = '';
    // The small tab that opens the menu without a controller button (hands, Vision Pro's pointer).
    this.tabPlane = new CanvasPlane([256, 96], [0.16, 0.06], 'menu-tab');
    this.tabCanvas = this.tabPlane.canvas;
    this.tabTexture = this.tabPlane.texture;
    this.tab = this.tabPlane.mesh;
    this.tab.renderOrder = 30;
    this.tab.visible = false;
    /** @type {boolean | null} */
    this.tabHover = null;
    this.#drawTab(false);
  }

  /**
   * Redraw when the state or the hovered button changed.
   * @param {import('../menu_state.js').MenuState} menu @param {string | null} hover @param {string} status
   */
  update(menu, hover, status) {
    // Closed, nothing is drawn: the link's status line changes with every pong (its latency), and each change
    // redrew the 1024x700 canvas and uploaded it, 0.3 ms a time with 100 robots' buttons (measured, CPU profile).
    if (!menu.open) return;
    const key = `${menu.version}|${hover}|${status}`;
    if (key === this.key) return;
    this.key = key;
    const [w, h] = MENU_PX;
    this.buttons = panelButtons(menu.buttons());
    this.rects = layoutMenu(this.buttons, w, h);
    const ctx = /** @type {CanvasRenderingContext2D} */ (this.canvas.getContext('2d'));
    ctx.clearRect(0, 0, w, h);
    fillRounded(ctx, [0, 0, w, h], 36, 'rgba(14,18,26,0.94)');
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'left';
    ctx.fillStyle = '#fff';
    ctx.font = font(30, 700);
    ctx.fillText('xr-relay', 28, 38);
    ctx.fillStyle = '#9aa5b8';
    fitText(ctx, status, 180, 39, w - 210, 22);
    for (const [group, title] of MENU_ROWS) {
      const first = this.rects.find((r) => this.buttons.find((b) => b.id === r.id)?.group === group);
      if (!first || !title) continue;
      ctx.fillStyle = '#6f7a8e';
      ctx.textAlign = 'left';
      fitText(ctx, title, 26, first.y + first.h / 2, 100, 22, 600);
    }
    for (const rect of this.rects) {
      const button = /** @type {import('../menu_state.js').MenuButton} */ (this.buttons.find((b) => b.id === rect.id));
      const hovered = hover === rect.id && button.enabled;
      if (button.caption) {
        ctx.fillStyle = '#c8d0dc';
        ctx.textAlign = 'center';
        // A study's question is read, not glanced at: its words as large as the row lets them be.
        const size = button.group.startsWith('question') ? 40 : 26;
        fitText(ctx, button.label, rect.x + rect.w / 2, rect.y + rect.h / 2 + 1, rect.w - 20, size, 600);
        continue;
      }
      roundRect(ctx, rect.x, rect.y, rect.w, rect.h, 16);
      ctx.fillStyle = button.danger
        ? hovered
          ? '#ff4d4d'
          : '#d31f1f'
        : button.active
          ? hovered
            ? '#3d8bff'
            : '#2a6fdb'
          : hovered
            ? '#3a4456'
            : '#252c3a';
      if (!button.enabled) ctx.globalAlpha = 0.4;
      ctx.fill();
      if (hovered) {
        ctx.lineWidth = 4;
        ctx.strokeStyle = '#fff';
        ctx.stroke();
      }
      ctx.fillStyle = '#fff';
      ctx.textAlign = 'center';
      fitText(
        ctx,
        button.label,
        rect.x + rect.w / 2,
        rect.y + rect.h / 2 + 1,
        rect.w - 20,
        button.danger ? 34 : 26,
        button.danger || button.active ? 700 : 500,
      );
      ctx.globalAlpha = 1;
    }
    this.texture.needsUpdate = true;
  }

  /** @param {boolean} hovered */
  #drawTab(hovered) {
    if (this.tabHover === hovered) return;
    this.tabHover = hovered;
    drawButtonFace(this.tabCanvas, '☰ Menu', hovered ? 'rgba(61,139,255,0.95)' : 'rgba(14,18,26,0.85)', 40, 40, 700);
    this.tabTexture.needsUpdate = true;
  }

  /** @param {boolean} hovered */
  setTabHover(hovered) {
    this.#drawTab(hovered);
  }

  /**
   * The button at a point of the panel's plane (a raycast's uv), or null.
   * @param {THREE.Vector2} uv
   */
  buttonAtUv(uv) {
    const [w, h] = MENU_PX;
    const id = buttonAt(this.rects, uv.x * w, (1 - uv.y) * h);
    const button = this.buttons.find((b) => b.id === id);
    return button && button.enabled ? button.id : null;
  }

  /** World positions of the buttons' centres (tests aim the emulated controllers at them). */
  buttonCentres() {
    const [w, h] = MENU_PX;
    /** @type {Record<string, number[]>} */
    const out = {};
    const v = new THREE.Vector3();
    this.mesh.updateWorldMatrix(true, false);
    for (const r of this.rects) {
      v.set(((r.x + r.w / 2) / w - 0.5) * MENU_M[0], (0.5 - (r.y + r.h / 2) / h) * MENU_M[1], 0);
      v.applyMatrix4(this.mesh.matrixWorld);
      out[r.id] = [v.x, v.y, v.z];
    }
    return out;
  }

  dispose() {
    this.plane.dispose();
    this.tabPlane.dispose();
  }
}

/** The sensor panel on the left wrist: a small canvas-textured plane on the left grip. */
export class WristPanel {
  constructor() {
    // 18 cm wide: at a forearm's length (~35 cm) its 26 px readings are about 1 degree tall, readable on a Quest 3.
    this.plane = new CanvasPlane([512, 400], [0.18, 0.14], 'wrist-panel');
    this.canvas = this.plane.canvas;
    this.texture = this.plane.texture;
    this.mesh = this.plane.mesh;
    this.mount('controller');
    this.mesh.raycast = () => {};
    this.lastDraw = -Infinity;
    this.key = '';
  }

  /**
   * Where the panel sits on what carries it, tilted towards the face like a watch: over the back of the hand that
   * holds a controller (on its grip), or, on a tracked hand's wrist joint (12 cm behind where a controller's grip
   * would be), over the back of the hand itself.
   * @param {'controller' | 'hand'} carrier
   */
  mount(carrier) {
    if (carrier === 'hand') this.mesh.position.set(0, 0.06, -0.03);
    else this.mesh.position.set(0, 0.09, 0.08);
    this.mesh.rotation.set(-Math.PI / 3.5, 0, 0);
  }

  /**
   * Redraw at most 4 times a second, and at once when the selection or the warnings change.
   * @param {import('./sensor_drawing.js').SensorPanelData} data
   */
  update(data) {
    const key = `${data.robot}|${data.link}|${data.sensors.map((s) => s.warning).join()}`;
    if (key === this.key && data.now - this.lastDraw < 250) return;
    this.key = key;
    this.lastDraw = data.now;
    drawSensorPanel(
      /** @type {CanvasRenderingContext2D} */ (this.canvas.getContext('2d')),
      this.canvas.width,
      this.canvas.height,
      data,
    );
    this.texture.needsUpdate = true;
  }

  dispose() {
    this.plane.dispose();
  }
}
