// @ts-check
/**
 * Inspection by pointing, in VR, with the menu's Inspect tool: a ray on a finding's pin opens its card (the
 * capture with its region, the note, the readings, status buttons); on a target's ring it picks that target for
 * the next mission, in order (the menu's "Inspect picked" sends them); on the twin's floor it makes a new target
 * there. On the card, a select on the image marks a region from that point (or makes a target where that pixel
 * looks), and the buttons set the status, accept or redo the region, and close. XRInteraction asks what the rays
 * may meet (`pickables`, `floorAt`), names a hit (`idOf`), and hands selects over (`select`); what is decided
 * is the inspection review's (pure), carried out by InspectionUi.
 *
 * In Robot POV the Inspect tool is the head-gaze dwell on the live image (xr_gaze.js's reticle): where the
 * dwell rests, a target where that pixel looks, a finding about a capture taken then, and the region around the point
 * proposed on its card, which opens in front of the operator when the relay has answered.
 *
 * Pins and rings are picked through walls: they are the operator's marks, drawn over the twin like RViz markers,
 * and an operator in the corridor reviews the rooms' findings without walking into each.
 */
import { Raycaster, Vector2 } from 'three';
import { appendNote, nextName } from '../inspection_review.js';

export class XRInspection {
  /**
   * @param {{ui: import('./inspection_ui.js').InspectionUi, card: import('./finding_card.js').FindingCard,
   *   picking: import('./picking.js').Picking, menu: import('../menu_state.js').MenuState,
   *   screen: import('./hemisphere_screen.js').HemisphereScreen,
   *   camera: import('three').Camera, notify: (text: string) => void, operator: () => boolean,
   *   dictation: import('./dictation.js').Dictation}} host
   */
  constructor(host) {
    this.host = host;
    /** The card button a ray hovers, for its highlight. @type {string | null} */
    this.hover = null;
    /**
     * The finding the card was last placed for (a newly opened one is placed in front of the operator).
     * @type {string | null}
     */
    this.placedFor = null;
  }

  /** The Inspect tool is on, in free roam, with the menu closed. */
  get active() {
    const menu = this.host.menu;
    return menu.tool === 'inspect' && menu.mode === 'free_roam' && !menu.open;
  }

  /** What the rays may meet: the card when it is shown, the pins and rings with the Inspect tool. */
  pickables() {
    const { card, ui, menu } = this.host;
    /** @type {import('three').Object3D[]} */
    const out = card.mesh.visible && !menu.open ? [card.mesh] : [];
    if (this.active) out.push(...ui.view.pickables());
    return out;
  }

  /**
   * The name of a hit: `insp:card:<button>`, `insp:image` (a point of the capture), `insp:finding:<id>`,
   * `insp:target:<id>`; null when it is none of ours or a disabled button.
   * @param {import('three').Intersection} hit
   */
  idOf(hit) {
    if (hit.object === this.host.card.mesh) {
      const what = hit.uv ? this.host.card.hitAtUv(hit.uv) : null;
      return what === null ? null : 'button' in what ? `insp:card:${what.button}` : 'insp:image';
    }
    for (let o = /** @type {import('three').Object3D | null} */ (hit.object); o; o = o.parent) {
      if (o.name.startsWith('finding:') || o.name.startsWith('target:')) return `insp:${o.name}`;
    }
    return null;
  }

  /**
   * With the Inspect tool, a ray that meets nothing else may point at the twin's floor: a new target there.
   * @param {import('three').Raycaster} raycaster
   * @returns {{id: string, point: import('three').Vector3} | null}
   */
  floorAt(raycaster) {
    if (!this.active || !this.host.operator()) return null;
    const hit = this.host.picking.pickTwin(raycaster);
    return hit?.floor ? { id: 'insp:floor', point: hit.point } : null;
  }

  /**
   * Whether the open finding's image shows an outline being judged (proposed, or asked for): a glance resting on it
   * then is reading it, not marking another (a CI run's headset, resting 1.5 s on the card while it waited, asked
   * for a region at the top of the image and lost the proposal that was to be accepted).
   */
  judging() {
    return this.host.ui.review.judging;
  }

  /**
   * In Robot POV with the Inspect tool, the pixel of the live image in a world direction from the eyes (null: not
   * here, not now, or off the image). @param {import('three').Vector3} direction
   * @returns {[number, number] | null}
   */
  liveAt(direction) {
    const { menu, screen } = this.host;
    if (menu.tool !== 'inspect' || menu.mode !== 'pov' || menu.open || !menu.selected || !this.host.operator())
      return null;
    return screen.pixelAt(direction);
  }

  /**
   * A click on the desktop's Robot POV panel with the Inspect tool (x, y: the panel's normalised device coordinates):
   * what a dwell does in the headset. Whether it marked anything. @param {number} x @param {number} y
   */
  clickPov(x, y) {
    const { menu, screen } = this.host;
    if (menu.tool !== 'inspect' || menu.mode !== 'pov' || !menu.selected || !this.host.operator()) return false;
    const raycaster = new Raycaster();
    raycaster.setFromCamera(new Vector2(x, y), screen.povCamera);
    const pixel = screen.pixelAt(raycaster.ray.direction);
    if (pixel) this.markLive(pixel);
    return pixel !== null;
  }

  /**
   * A dwell on the live image at a pixel (from liveAt): a target there, and its region. @param {[number, number]} pixel
   */
  markLive(pixel) {
    const { ui, menu } = this.host;
    if (!menu.selected) return;
    const commands = ui.review.liveClick(ui.model, menu.selected, pixel[0], pixel[1]);
    const first = commands[0];
    if (!first || first.type !== 'target_live') return;
    ui.run(commands);
    this.host.notify(`marking ${first.target} where ${menu.selected} looks…`);
  }

  /** The ids the rays hover now (the card highlights its button). @param {(string | null)[]} hovered */
  setHover(hovered) {
    const button = hovered.find((h) => h?.startsWith('insp:card:'));
    this.hover = button ? button.slice('insp:card:'.length) : null;
  }

  /**
   * A select on one of ours.
   * @param {string} id from idOf or floorAt
   * @param {{point: import('three').Vector3, uv?: import('three').Vector2 | null} | null} hit
   */
  select(id, hit) {
    const { ui, card } = this.host;
    const review = ui.review;
    const model = ui.model;
    if (id.startsWith('insp:card:')) this.#button(id.slice('insp:card:'.length));
    else if (id === 'insp:image') {
      const what = hit?.uv ? card.hitAtUv(hit.uv) : null;
      if (what && 'pixel' in what && this.host.operator())
        ui.run(review.imageClick(model, what.pixel[0], what.pixel[1]));
    } else if (id.startsWith('insp:finding:')) {
      review.select(id.slice('insp:finding:'.length));
    } else if (id.startsWith('insp:target:')) {
      const target = id.slice('insp:target:'.length);
      review.togglePick(target);
      const n = review.picked.indexOf(target);
      this.host.notify(n >= 0 ? `${target} picked (${n + 1}): Menu › Mission › Inspect picked` : `${target} unpicked`);
    } else if (id === 'insp:floor' && hit) {
      const { x, y } = this.host.picking.sceneToMapPoint(hit.point);
      const name = nextName(model, 'point');
      ui.run([{ type: 'target_at', target: name, x, y }]);
      this.host.notify(`new target ${name} at (${x.toFixed(1)}, ${y.toFixed(1)})`);
    }
    ui.update(this.host.menu);
  }

  /** @param {string} button */
  #button(button) {
    const review = this.host.ui.review;
    if (button === 'card:close') review.select(null);
    else if (button === 'card:before' || button === 'card:after' || button === 'card:image')
      this.host.card.show(button === 'card:before' ? 'before' : 'after');
    else if (button === 'card:note') this.host.card.read();
    else if (button === 'note:clear') this.host.ui.run(review.setNote(''));
    else if (button === 'note:dictate') {
      const finding = review.selected;
      // The phrase is added to the note as the relay has it then; the card may have moved on meanwhile.
      this.host.dictation.start((text) => {
        const note = finding ? this.host.ui.model.findings.get(finding)?.note : undefined;
        if (finding && note !== undefined) this.host.ui.run(review.setNote(appendNote(note, text), finding));
      });
    } else if (button.startsWith('status:'))
      this.host.ui.run(review.setStatus(/** @type {any} */ (button.slice('status:'.length))));
    else if (button === 'region:accept') this.host.ui.run(review.accept());
    else if (button === 'region:redo') review.redo();
    else if (button === 'image:region' || button === 'image:target')
      review.setImageAction(button === 'image:region' ? 'region' : 'target');
  }

  /** Draw the card for this frame (it redraws only on a change). @param {boolean} presenting */
  update(presenting) {
    const { ui, card } = this.host;
    if (ui.review.selected !== this.placedFor) {
      this.placedFor = ui.review.selected;
      if (presenting && this.placedFor) card.place(this.host.camera);
    }
    const dictation = this.host.dictation.state;
    card.update(ui.review, ui.model, { operator: this.host.operator(), presenting, hover: this.hover, dictation });
  }
}
