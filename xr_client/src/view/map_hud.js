// @ts-check
/**
 * The desktop map's compass and scale bar, in the top-left corner of the part of the window no panel covers: the
 * compass points to the map's north (REP 103: +y) as the view shows it; the scale bar is a round length at the orbit
 * centre's distance. The page is written only when they change.
 */
import * as THREE from 'three';
import { mapToScene } from '../frames.js';
import { scaleBar } from '../layout.js';

export class MapHud {
  /**
   * @param {{camera: THREE.PerspectiveCamera, orbit: import('three/addons/controls/OrbitControls.js').OrbitControls,
   *   fleet: import('../fleet_model.js').FleetModel}} host the view it measures, and the map's frame
   */
  constructor(host) {
    this.host = host;
    /** North's screen angle, degrees clockwise from up (CSS rotate). */
    this.compass = 0;
    this.scale = { metres: 1, px: 0, text: '' };
    this.hud = document.getElementById('map-hud');
    this.needle = /** @type {HTMLElement | null} */ (this.hud?.querySelector('.needle') ?? null);
    this.bar = /** @type {HTMLElement | null} */ (this.hud?.querySelector('.bar') ?? null);
    this.barText = /** @type {HTMLElement | null} */ (this.hud?.querySelector('.bar-text') ?? null);
  }

  /**
   * Per frame, after the view moved.
   * @param {import('../layout.js').Rect} free the part of the window no panel covers
   * @param {number} w @param {number} h the canvas' size (px)
   */
  update(free, w, h) {
    const { camera, orbit, fleet } = this.host;
    const t = fleet.scene.mapToScene;
    const a = new THREE.Vector3(...mapToScene(t, 0, 0)).sub(new THREE.Vector3(...mapToScene(t, 0, -1)));
    const centre = orbit.target.clone();
    const p0 = centre.clone().project(camera);
    const p1 = centre.clone().add(a).project(camera);
    // Screen angle of north, clockwise from up (CSS rotate).
    const sx = ((p1.x - p0.x) / 2) * w;
    const sy = ((p1.y - p0.y) / 2) * h;
    const compass = Math.round((Math.atan2(sx, sy) * 180) / Math.PI);
    // Pixels per metre across the screen at the orbit centre.
    const right = new THREE.Vector3(1, 0, 0).applyQuaternion(camera.quaternion);
    const p2 = centre.clone().add(right).project(camera);
    const scale = scaleBar(Math.hypot(((p2.x - p0.x) / 2) * w, ((p2.y - p0.y) / 2) * h));
    if (compass !== this.compass && this.needle) this.needle.style.transform = `rotate(${compass}deg)`;
    this.compass = compass;
    if (scale.text !== this.scale.text || Math.abs(scale.px - this.scale.px) > 0.5) {
      if (this.bar) this.bar.style.width = `${scale.px.toFixed(1)}px`;
      if (this.barText) this.barText.textContent = scale.text;
    }
    this.scale = scale;
    if (this.hud) {
      // In the free part's top-left corner: over the view, never under a panel.
      const left = `${free.left + 4}px`;
      const top = `${free.top + 4}px`;
      if (this.hud.style.left !== left) this.hud.style.left = left;
      if (this.hud.style.top !== top) this.hud.style.top = top;
    }
  }
}
