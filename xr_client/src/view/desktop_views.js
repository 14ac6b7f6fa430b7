// @ts-check
/**
 * The desktop camera's views and the map's compass and scale bar.
 *
 * - The view is centred on the part of the window no panel covers (layout.js freeRect; a projection offset,
 *   so the whole canvas is still drawn): what the operator orbits, frames or follows is never under the menu or
 *   the Robot POV panel.
 * - **Frame fleet** (H, Home): the map's floor and every robot fitted into that free part, from the current
 *   direction (from the south-east above the first time). **Top-down** (T): straight down, north up, fitted the
 *   same way; it lasts until the operator tilts the view. **Follow** (F): the orbit centre rides with the selected
 *   robot, whatever the operator's angle and zoom; panning or flying away ends it. In Robot POV the viewed robot
 *   is followed the same way, so the POV panel never hides it.
 * - The compass points to the map's north (REP 103: +y) as the view shows it; the scale bar is a round length at
 *   the orbit centre's distance (view/map_hud.js).
 */
import * as THREE from 'three';
import { mapToScene } from '../frames.js';
import { freeRect } from '../layout.js';
import { MapHud } from './map_hud.js';

/** How often the panels' rectangles are read (ms): reading them forces a layout, never per frame. */
const LAYOUT_EVERY = 250;
/** Share of the free part the fitted floor may fill. */
const FIT = 0.92;
/** Closest follow distance (m) when following starts from afar: the robot fills a useful part of the view. */
const FOLLOW_DISTANCE = 7;

/** @typedef {'orbit' | 'top' | 'follow'} ViewMode */

export class DesktopViews {
  /**
   * @param {{camera: THREE.PerspectiveCamera, orbit: import('three/addons/controls/OrbitControls.js').OrbitControls,
   *   canvas: HTMLCanvasElement, fleet: import('../fleet_model.js').FleetModel,
   *   robotViews: Map<string, import('./robot_view.js').RobotView>, menu: import('../menu_state.js').MenuState}} host
   */
  constructor(host) {
    this.host = host;
    /** @type {ViewMode} */
    this.mode = 'orbit';
    /** @type {import('../layout.js').Rect} */
    this.free = { left: 0, top: 0, right: host.canvas.clientWidth, bottom: host.canvas.clientHeight };
    this.lastLayout = -Infinity;
    this.offsetKey = '';
    /** Where the followed robot was last frame (scene), or null. @type {THREE.Vector3 | null} */
    this.followed = null;
    /** The last framing ('frame' or 'top') until the operator moves the view: while set, a change of the panels
     * (one opens, the window is resized) frames again. @type {'frame' | 'top' | null} */
    this.auto = null;
    /** The first framing looks from the south, above; later ones keep the operator's direction. */
    this.framedOnce = false;
    /** @type {number | undefined} */
    this.width = undefined;
    /** @type {number | undefined} */
    this.height = undefined;
    /** The compass and the scale bar. */
    this.mapHud = new MapHud(host);
    this.toolbar = document.getElementById('views');
    /** @type {(() => void)[]} */
    this.unlisten = [];
    const onClick = (/** @type {MouseEvent} */ e) => {
      const button = /** @type {HTMLElement | null} */ (
        /** @type {HTMLElement} */ (e.target).closest('button[data-view]')
      );
      if (button) this.choose(/** @type {string} */ (button.dataset.view));
    };
    this.toolbar?.addEventListener('click', onClick);
    this.unlisten.push(() => this.toolbar?.removeEventListener('click', onClick));
    const onChange = () => {
      // Top-down lasts while the view looks straight down; a tilt (a left drag) makes it a free orbit again.
      if (this.mode === 'top' && host.orbit.getPolarAngle() > 0.05) this.#setMode('orbit');
    };
    host.orbit.addEventListener('change', onChange);
    const onStart = () => (this.auto = null); // the operator's hand on the view (a drag, the wheel)
    host.orbit.addEventListener('start', onStart);
    this.unlisten.push(
      () => host.orbit.removeEventListener('change', onChange),
      () => host.orbit.removeEventListener('start', onStart),
    );
  }

  /** A toolbar button or its key. @param {string} view 'frame' | 'top' | 'follow' */
  choose(view) {
    if (view === 'frame') this.frame();
    else if (view === 'top') this.top();
    else if (view === 'follow') this.follow(this.mode !== 'follow');
  }

  /** Fit the fleet's floor into the free part of the window, from the current direction (or the first one). */
  frame() {
    const { camera, orbit } = this.host;
    const box = fleetBox(this.host.fleet);
    const centre = box.getCenter(new THREE.Vector3());
    const direction = camera.position.clone().sub(orbit.target);
    if (direction.lengthSq() < 1e-6 || !this.framedOnce) direction.set(0, 0.85, 0.5); // from the south, above
    this.framedOnce = true;
    this.#setMode('orbit');
    this.#fit(box, centre, direction.normalize());
    this.auto = 'frame';
  }

  /** Straight down on the fleet's floor, north up. */
  top() {
    const t = this.host.fleet.scene.mapToScene;
    const origin = new THREE.Vector3(...mapToScene(t, 0, 0));
    const south = origin.sub(new THREE.Vector3(...mapToScene(t, 0, 1))).normalize();
    const box = fleetBox(this.host.fleet);
    // A hair to the south: straight down with "up" on screen toward the map's north.
    this.#fit(
      box,
      box.getCenter(new THREE.Vector3()),
      new THREE.Vector3(0, 1, 0).addScaledVector(south, 1e-4).normalize(),
    );
    this.#setMode('top');
    this.auto = 'top';
  }

  /** Follow the selected robot (or stop following). @param {boolean} on */
  follow(on) {
    if (!on) {
      if (this.mode === 'follow') this.#setMode('orbit');
      return;
    }
    const view = this.host.robotViews.get(this.host.menu.selected ?? '');
    if (!view?.group.visible) return;
    const { camera, orbit } = this.host;
    const offset = camera.position.clone().sub(orbit.target);
    if (offset.length() > FOLLOW_DISTANCE) offset.setLength(FOLLOW_DISTANCE);
    orbit.target.copy(view.group.position);
    camera.position.copy(view.group.position).add(offset);
    this.followed = view.group.position.clone();
    this.#setMode('follow');
    this.auto = null;
  }

  /** Per frame, before the orbit's update. @param {number} now */
  update(now) {
    const { canvas } = this.host;
    if (
      now - this.lastLayout > LAYOUT_EVERY ||
      canvas.clientWidth !== this.width ||
      canvas.clientHeight !== this.height
    ) {
      // Framed and untouched since: the fleet stays framed in what the panels leave free.
      if (this.layout(now) && this.auto) this.choose(this.auto);
    }
    const pov = this.host.menu.mode === 'pov';
    if (this.mode === 'follow' || pov) this.#track(pov);
    this.mapHud.update(this.free, this.width ?? 1, this.height ?? 1);
  }

  /**
   * Read the panels and centre the projection on the free part of the window; true when that part changed.
   * @param {number} now
   */
  layout(now) {
    this.lastLayout = now;
    const { canvas, camera } = this.host;
    this.width = canvas.clientWidth;
    this.height = canvas.clientHeight;
    const panels = ['menu', 'sensors', 'pov-panel', 'findings', 'help', 'views']
      .map((id) => document.getElementById(id))
      .filter((e) => e !== null && !e.hidden && e.getClientRects().length > 0)
      .map((e) => /** @type {HTMLElement} */ (e).getBoundingClientRect());
    const header = document.querySelector('header')?.getBoundingClientRect();
    if (header) panels.push(new DOMRect(0, 0, this.width, header.bottom));
    const free = freeRect({ width: this.width, height: this.height }, panels);
    const moved = JSON.stringify(free) !== JSON.stringify(this.free);
    this.free = free;
    const dx = (this.free.left + this.free.right) / 2 - this.width / 2;
    const dy = (this.free.top + this.free.bottom) / 2 - this.height / 2;
    const key = `${this.width}x${this.height}|${dx}|${dy}`;
    if (key !== this.offsetKey && this.width && this.height) {
      this.offsetKey = key;
      // The full frustum's centre lands at the free part's centre: a view offset of minus that shift.
      camera.setViewOffset(this.width, this.height, -dx, -dy, this.width, this.height);
    }
    return moved;
  }

  /** Entering VR: the headset's projection rules. */
  suspend() {
    this.host.camera.clearViewOffset();
    this.offsetKey = '';
  }

  /** @param {boolean} pov the viewed robot in Robot POV */
  #track(pov) {
    const { camera, orbit } = this.host;
    const view = this.host.robotViews.get(this.host.menu.selected ?? '');
    if (!view?.group.visible) {
      if (!pov) this.#setMode('orbit');
      return;
    }
    // Panned or flown off the robot (the centre left it by more than the robot's size): following ends. In
    // Robot POV the robot is brought back to the centre instead.
    const off = this.followed === null || orbit.target.distanceTo(this.followed) > 0.3;
    if (off && !pov && this.followed !== null) {
      this.#setMode('orbit');
      return;
    }
    const delta = view.group.position.clone().sub(off ? orbit.target : /** @type {THREE.Vector3} */ (this.followed));
    orbit.target.add(delta);
    camera.position.add(delta);
    this.followed = view.group.position.clone();
  }

  /** @param {ViewMode} mode */
  #setMode(mode) {
    this.mode = mode;
    if (mode !== 'follow') this.followed = null;
    for (const button of this.toolbar?.querySelectorAll('button[data-view]') ?? []) {
      const view = /** @type {HTMLElement} */ (button).dataset.view;
      button.setAttribute('aria-pressed', String(view === mode));
    }
  }

  /**
   * Put the orbit centre on `centre` and the camera along `direction` at the distance where the box fills the free
   * part of the window (FIT), found by bisection on the projected corners.
   * @param {THREE.Box3} box @param {THREE.Vector3} centre @param {THREE.Vector3} direction unit, centre to camera
   */
  #fit(box, centre, direction) {
    const { camera, orbit } = this.host;
    this.layout(performance.now());
    /** @type {THREE.Vector3[]} */
    const corners = [];
    for (const x of [box.min.x, box.max.x])
      for (const y of [0, 1]) for (const z of [box.min.z, box.max.z]) corners.push(new THREE.Vector3(x, y, z));
    const { width, height } = this;
    const f = this.free;
    const fits = (/** @type {number} */ d) => {
      camera.position.copy(centre).addScaledVector(direction, d);
      camera.lookAt(centre);
      camera.updateMatrixWorld(true);
      const p = new THREE.Vector3();
      return corners.every((c) => {
        p.copy(c).project(camera);
        if (p.z > 1) return false;
        const x = ((p.x + 1) / 2) * (width ?? 1);
        const y = ((1 - p.y) / 2) * (height ?? 1);
        const mx = ((1 - FIT) / 2) * (f.right - f.left);
        const my = ((1 - FIT) / 2) * (f.bottom - f.top);
        return x >= f.left + mx && x <= f.right - mx && y >= f.top + my && y <= f.bottom - my;
      });
    };
    let near = 1;
    let far = 400;
    for (let i = 0; i < 30; i++) {
      const mid = (near + far) / 2;
      if (fits(mid)) far = mid;
      else near = mid;
    }
    camera.position.copy(centre).addScaledVector(direction, far);
    orbit.target.copy(centre);
    orbit.update();
  }

  dispose() {
    for (const off of this.unlisten) off();
    this.unlisten = [];
  }
}

/**
 * The floor of the bounds, or around the robots: what the desktop camera frames.
 * @param {import('../fleet_model.js').FleetModel} fleet
 */
export function fleetBox(fleet) {
  const box = new THREE.Box3();
  const t = fleet.scene.mapToScene;
  if (fleet.bounds) {
    const [a, b, c, d] = fleet.bounds;
    box
      .expandByPoint(new THREE.Vector3(...mapToScene(t, a, b)))
      .expandByPoint(new THREE.Vector3(...mapToScene(t, c, d)));
  }
  for (const r of fleet.robots.values())
    if (r.pose) box.expandByPoint(new THREE.Vector3(...mapToScene(t, r.pose.x, r.pose.y)));
  if (box.isEmpty()) box.set(new THREE.Vector3(-5, 0, -5), new THREE.Vector3(5, 0, 5));
  return box;
}
