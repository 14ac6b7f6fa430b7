// @ts-check
/**
 * The head's gaze in VR, once per XR frame: a dwell (gestures.js) on a point of a finding's image (unless an outline
 * on it is being judged), of the live Robot POV image, or (with the menu's Gaze press option) on a menu button acts
 * there, and a reticle at the centre of view fills while the dwell runs.
 */
import * as THREE from 'three';
import { Dwell } from '../gestures.js';

/** After a dwell acts, how far the head turns before the next can start (rad). */
const GAZE_AWAY_RAD = (5 * Math.PI) / 180;

export class GazeDwell {
  /**
   * @param {{camera: THREE.PerspectiveCamera, menu: import('../menu_state.js').MenuState,
   *   menuPanel: import('./panels.js').MenuPanel, inspect: import('./xr_inspection.js').XRInspection,
   *   actions: import('../app.js').OperatorActions}} host what the gaze reads and drives
   */
  constructor(host) {
    this.host = host;
    this.raycaster = new THREE.Raycaster();
    /** Head-gaze dwell: a reticle at the centre of view fills while the gaze rests on a point (gestures.js). */
    this.dwell = new Dwell();
    this.reticle = new Reticle();
    host.camera.add(this.reticle.group);
    /**
     * The gaze's direction when a dwell last acted: the next dwell waits until the head has turned away from it.
     * @type {THREE.Vector3 | null}
     */
    this.spentGaze = null;
    /** The dwell's last state, for the state snapshot. */
    this.gaze = { id: /** @type {string | null} */ (null), fill: 0, fired: 0 };
  }

  /**
   * The head's gaze, for a dwell: on a point of a finding's image it selects there (a region from that point, or a
   * target where that pixel looks, as the card's mode says), and on a menu button it presses it only when the menu's
   * **Gaze press** option is on. @param {THREE.Object3D[]} targets what rays can hit now
   */
  update(targets) {
    const host = this.host;
    const camera = host.camera;
    this.raycaster.set(camera.getWorldPosition(new THREE.Vector3()), camera.getWorldDirection(new THREE.Vector3()));
    this.raycaster.far = 20;
    const first = this.raycaster.intersectObjects(targets, true)[0] ?? null;
    let id = null;
    /** @type {[number, number] | null} */
    let live = null;
    if (first?.object === host.menuPanel.mesh && first.uv)
      id = host.menu.options.dwellPress ? host.menuPanel.buttonAtUv(first.uv) : null;
    else if (first) {
      const name = host.inspect.idOf(first);
      id = name === 'insp:image' && !host.inspect.judging() ? name : null;
    } else if ((live = host.inspect.liveAt(this.raycaster.ray.direction))) id = 'pov:image';
    // On the live image (5 m away, around the eyes) the gaze's steadiness is judged 1 m out: 3 degrees of wander.
    const at = first ? first.point : live ? this.raycaster.ray.at(1, new THREE.Vector3()) : null;
    const point = at ? /** @type {[number, number, number]} */ (at.toArray()) : null;
    // What a dwell opens may appear under the gaze (the finding card, in front of the eyes): nothing more is dwelt
    // on until the head turns away, 5 degrees, from where the last dwell acted.
    const spent = this.spentGaze !== null && this.raycaster.ray.direction.angleTo(this.spentGaze) < GAZE_AWAY_RAD;
    if (!spent) this.spentGaze = null;
    if (spent) id = null;
    const { fill, fire } = this.dwell.update(id && point ? { id, point } : null, performance.now());
    this.reticle.setFill(fill);
    this.gaze.id = id;
    this.gaze.fill = fill;
    if (!fire || !id) return;
    this.gaze.fired++;
    this.spentGaze = this.raycaster.ray.direction.clone();
    if (id === 'pov:image' && live) host.inspect.markLive(live);
    else if (!first) return;
    else if (id === 'insp:image') host.inspect.select(id, first);
    else host.actions.pressMenu(id);
  }

  dispose() {
    this.reticle.dispose();
  }
}

/** The gaze reticle: a faint ring at the centre of view, and an arc that fills while a dwell runs. */
class Reticle {
  constructor() {
    this.group = new THREE.Group();
    this.group.position.set(0, 0, -1);
    const material = new THREE.MeshBasicMaterial({
      color: 0xffffff,
      transparent: true,
      opacity: 0.5,
      depthTest: false,
    });
    this.ring = new THREE.Mesh(new THREE.RingGeometry(0.008, 0.011, 32), material);
    this.arcMaterial = new THREE.MeshBasicMaterial({ color: 0x3d8bff, depthTest: false });
    this.arc = new THREE.Mesh(new THREE.RingGeometry(0.012, 0.017, 32, 1, Math.PI / 2, 0.001), this.arcMaterial);
    this.ring.renderOrder = this.arc.renderOrder = 20;
    // Only the headset's eyes see it (three.js's XR cameras enable layers 1 and 2; the desktop camera has 0 alone).
    for (const mesh of [this.ring, this.arc]) {
      mesh.layers.disableAll();
      mesh.layers.enable(1);
      mesh.layers.enable(2);
    }
    this.group.add(this.ring, this.arc);
    this.fill = 0;
  }

  /** @param {number} fill 0..1 */
  setFill(fill) {
    const rounded = Math.round(fill * 24) / 24; // a new ring at most 24 times a dwell
    if (rounded === this.fill) return;
    this.fill = rounded;
    this.arc.geometry.dispose();
    this.arc.geometry = new THREE.RingGeometry(
      0.012,
      0.017,
      32,
      1,
      Math.PI / 2,
      Math.max(0.001, rounded * Math.PI * 2),
    );
    this.arc.visible = rounded > 0;
  }

  dispose() {
    this.group.removeFromParent();
    this.ring.geometry.dispose();
    this.arc.geometry.dispose();
    /** @type {THREE.Material} */ (this.ring.material).dispose();
    this.arcMaterial.dispose();
  }
}
