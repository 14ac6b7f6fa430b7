// @ts-check
/**
 * The finding card in VR: the open finding's capture with its region (or the outline the relay proposes), its
 * note and readings, its reading's trend over the last rounds (a sparkline, the threshold dashed), and buttons to
 * set its status, mark a region (select a point of the image), make a target where a pixel looks, accept or redo a
 * region, and close. Note reads the whole note in the image's place, where it is dictated (dictation.js) or
 * cleared. A canvas-textured plane placed in front of the operator when a pin is selected; it redraws only when the
 * review, the finding, the hover or the image changed. Where things sit and what a hit means is
 * finding_card_layout.js (pure, tested in node).
 */
import * as THREE from 'three';
import { CanvasPlane } from './canvas_plane.js';
import { fillRounded, fitText, font, wrapLines } from './canvas_text.js';
import { CARD_PX, cardHit, cardLayout, pixelToCard } from '../finding_card_layout.js';
import { drawTrend } from './card_trend.js';
import { CardImage } from './card_image.js';
import { STATUS_COLOURS } from '../change_colour.js';
import { statusWords } from '../wording.js';

/** @type {[number, number]} */
const CARD_M = [0.64, 0.4];
const CARD_DISTANCE = 0.8;

export class FindingCard {
  /** @param {string | null} token the operator token, for the capture images */
  constructor(token) {
    this.token = token;
    this.plane = new CanvasPlane(CARD_PX, CARD_M, 'finding-card');
    this.mesh = this.plane.mesh;
    this.mesh.renderOrder = 30;
    this.mesh.visible = false;
    /** The capture, and a changed finding's before image (the capture it was compared with). */
    this.after = new CardImage();
    this.before = new CardImage();
    /** Which of them the card shows: a changed finding's Before and After buttons switch (the desktop's slider). */
    this.showing = /** @type {'after' | 'before'} */ ('after');
    /** Whether the note is read in the image's place, and the lines the last draw showed of it. */
    this.reading = false;
    /** @type {string[]} */
    this.noteLines = [];
    this.findingId = '';
    /** @type {ReturnType<typeof cardLayout>} */
    this.layout = cardLayout({
      status: '',
      proposal: false,
      imageAction: 'region',
      operator: false,
      imageSize: null,
      before: null,
    });
    this.key = '';
    this.draws = 0;
  }

  /**
   * Show the review's open finding (hide the card when none), redrawing only what changed.
   * @param {import('../inspection_review.js').InspectionReview} review
   * @param {import('../inspection_model.js').InspectionModel} model
   * @param {{operator: boolean, presenting: boolean, hover: string | null,
   *   dictation: 'none' | 'ready' | 'listening'}} context
   */
  update(review, model, context) {
    const finding = review.selected ? model.findings.get(review.selected) : null;
    this.mesh.visible = Boolean(finding) && context.presenting;
    if (!finding || !context.presenting) return;
    const query = this.token ? `?token=${encodeURIComponent(this.token)}` : '';
    this.after.load(finding.image ? `${finding.image}${query}` : '');
    this.before.load(finding.before ? `${finding.before}${query}` : '');
    if (finding.id !== this.findingId) [this.findingId, this.showing, this.reading] = [finding.id, 'after', false];
    const version = `${finding.id}|${finding.updated}|${review.version}`;
    const images = `${this.after.state}|${this.before.state}|${this.showing}|${this.reading}`;
    const key = `${version}|${context.hover}|${context.operator}|${images}|${context.dictation}`;
    if (key === this.key) return;
    this.key = key;
    this.layout = cardLayout({
      status: finding.status,
      proposal: review.proposal !== null,
      imageAction: review.imageAction,
      operator: context.operator,
      imageSize: this.imageSize,
      before: finding.before ? this.showing : null,
      note: this.reading,
      dictation: context.dictation,
    });
    this.#draw(finding, review.outline(model), review.hint(), context.hover);
  }

  /** The capture's size, once its image has loaded (a hit on the image maps back to its pixels). */
  get imageSize() {
    return this.after.size;
  }

  /** Show the capture or, for a changed finding, its before image. @param {'after' | 'before'} which */
  show(which) {
    [this.showing, this.reading] = [which, false];
  }

  /** Read the note in the image's place. */
  read() {
    this.reading = true;
  }

  /**
   * @param {import('../protocol.js').FindingMessage} finding @param {number[][] | null} outline
   * @param {string} hint @param {string | null} hover
   */
  #draw(finding, outline, hint, hover) {
    const [w, h] = CARD_PX;
    const ctx = /** @type {CanvasRenderingContext2D} */ (this.plane.canvas.getContext('2d'));
    ctx.clearRect(0, 0, w, h);
    fillRounded(ctx, [0, 0, w, h], 32, 'rgba(14,18,26,0.95)');
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'left';
    ctx.fillStyle = STATUS_COLOURS[finding.status];
    ctx.beginPath();
    ctx.arc(40, 34, 12, 0, Math.PI * 2);
    ctx.fill();
    ctx.fillStyle = '#fff';
    const shown = this.showing === 'before' && finding.before ? this.before : this.after;
    fitText(
      ctx,
      `${finding.target ?? 'finding'} · ${finding.robot} · ${statusWords(finding.status)}` +
        (this.reading
          ? ' · note'
          : finding.before
            ? ` · ${this.showing === 'before' ? 'before (the last round)' : 'after'}`
            : ''),
      64,
      34,
      w - 100,
      30,
      700,
    );
    const box = this.layout.image;
    if (this.layout.note) this.#note(ctx, this.layout.note, finding.note);
    else if (box && shown.image && shown.size && this.imageSize) {
      ctx.drawImage(shown.image, box.x, box.y, box.w, box.h);
      if (outline && outline.length > 2 && shown === this.after) this.#outline(ctx, box, this.imageSize, outline);
    } else {
      ctx.fillStyle = '#9aa5b8';
      fitText(
        ctx,
        shown.state === 'failed' ? 'the image could not be loaded' : finding.image ? 'loading the image…' : 'no image',
        40,
        h / 2,
        560,
        26,
      );
    }
    const text = this.layout.text;
    ctx.fillStyle = '#dfe6f0';
    fitText(ctx, finding.note || '(no note)', text.x, text.y + 20, text.w, 24);
    ctx.fillStyle = '#9aa5b8';
    const readings = Object.entries(finding.readings)
      .map(([k, v]) => `${k} ${v.toFixed(1)}`)
      .join(' · ');
    fitText(ctx, readings || 'no readings', text.x, text.y + 60, text.w, 22);
    fitText(ctx, hint, text.x, text.y + 100, text.w, 20);
    // One round is a reading, not a trend.
    if ((finding.trend?.points.length ?? 0) >= 2 && finding.trend) drawTrend(ctx, this.layout.trend, finding.trend);
    for (const b of this.layout.buttons) {
      const hovered = hover === b.id && b.enabled;
      ctx.globalAlpha = b.enabled ? 1 : 0.4;
      fillRounded(
        ctx,
        [b.x, b.y, b.w, b.h],
        14,
        b.active ? (hovered ? '#3d8bff' : '#2a6fdb') : hovered ? '#3a4456' : '#252c3a',
      );
      ctx.fillStyle = '#fff';
      ctx.textAlign = 'center';
      fitText(ctx, b.label, b.x + b.w / 2, b.y + b.h / 2 + 1, b.w - 16, 24, b.active ? 700 : 500);
      ctx.textAlign = 'left';
    }
    ctx.globalAlpha = 1;
    this.plane.texture.needsUpdate = true;
    this.draws++;
  }

  /**
   * The whole note, wrapped: 20 px text (12 mm on the 0.64 m card, 0.9 degrees at its 0.8 m) on 24 px lines fits
   * 1000 characters of words, 22 lines of 50 or so.
   * @param {CanvasRenderingContext2D} ctx @param {{x: number, y: number, w: number, h: number}} box
   * @param {string} note
   */
  #note(ctx, box, note) {
    fillRounded(ctx, [box.x, box.y, box.w, box.h], 14, '#1b2230');
    ctx.font = font(20);
    const line = 24;
    const lines = note ? wrapLines(ctx, note, box.w - 32, Math.floor((box.h - 24) / line)) : [];
    ctx.fillStyle = note ? '#dfe6f0' : '#9aa5b8';
    lines.forEach((text, i) => ctx.fillText(text, box.x + 16, box.y + 12 + line * (i + 0.5)));
    if (!note) fitText(ctx, '(no note yet)', box.x + 16, box.y + 12 + line / 2, box.w - 32, 20);
    this.noteLines = lines;
  }

  /**
   * @param {CanvasRenderingContext2D} ctx @param {{x: number, y: number, w: number, h: number}} box
   * @param {[number, number]} size @param {number[][]} outline capture pixels
   */
  #outline(ctx, box, size, outline) {
    ctx.beginPath();
    outline.forEach(([u, v], i) => {
      const [x, y] = pixelToCard(box, size, u, v);
      if (i === 0) ctx.moveTo(x, y);
      else ctx.lineTo(x, y);
    });
    ctx.closePath();
    ctx.fillStyle = 'rgba(255,200,40,0.25)';
    ctx.fill();
    ctx.lineWidth = 4;
    ctx.strokeStyle = '#ffc828';
    ctx.stroke();
  }

  /**
   * What a ray's hit on the card means (a raycast's uv). @param {THREE.Vector2} uv
   * @returns {{button: string} | {pixel: [number, number]} | null}
   */
  hitAtUv(uv) {
    return cardHit(this.layout, this.imageSize, uv.x * CARD_PX[0], (1 - uv.y) * CARD_PX[1]);
  }

  /** Place the card in front of the operator, a little below the eyes, facing them. @param {THREE.Camera} camera */
  place(camera) {
    const head = camera.getWorldPosition(new THREE.Vector3());
    const forward = camera.getWorldDirection(new THREE.Vector3());
    forward.y = 0;
    if (forward.lengthSq() < 1e-6) forward.set(0, 0, -1);
    forward.normalize();
    this.mesh.position.copy(head).addScaledVector(forward, CARD_DISTANCE);
    this.mesh.position.y = head.y - 0.15;
    this.mesh.lookAt(head.x, this.mesh.position.y + 0.1, head.z);
  }

  /**
   * World points of the card (tests aim the emulated controllers at them): each button's centre, and a pixel
   * of the capture when asked.
   * @param {[number, number] | null} [pixel]
   */
  points(pixel = null) {
    const [w, h] = CARD_PX;
    this.mesh.updateWorldMatrix(true, false);
    const world = (/** @type {number} */ x, /** @type {number} */ y) => {
      const v = new THREE.Vector3((x / w - 0.5) * CARD_M[0], (0.5 - y / h) * CARD_M[1], 0).applyMatrix4(
        this.mesh.matrixWorld,
      );
      return [v.x, v.y, v.z];
    };
    /** @type {Record<string, number[]>} */
    const out = Object.fromEntries(this.layout.buttons.map((b) => [b.id, world(b.x + b.w / 2, b.y + b.h / 2)]));
    if (pixel && this.layout.image && this.imageSize)
      out.pixel = world(...pixelToCard(this.layout.image, this.imageSize, pixel[0], pixel[1]));
    return out;
  }

  dispose() {
    this.plane.dispose();
  }
}
