// @ts-check
/**
 * The robots in the twin: one RobotView per robot of the fleet, placed every frame from the smoothed poses
 * and labelled with their status; the parts every robot shares (fleet_instances.js) and the label atlas
 * (label_atlas.js) are built here with the fleet. Views are rebuilt only when the fleet (or a robot's model)
 * changes. The map's annotations (room names, grid, north arrow) come with the fleet's hello and live here too.
 *
 * Per frame, for every robot: its pose (in place, no allocation), its label's size and fade (label_rule.js), and
 * which robots get their full model (level_of_detail.js). Statuses (the label's words, the tint) are refreshed
 * for STATUS_PER_FRAME robots a frame in turn, all of them in a few frames: text the eye reads, not a per-frame
 * rebuild of 100 strings (and the selection ring at once, every frame).
 */
import { declutter, labelRect } from '../label_declutter.js';
import * as THREE from 'three';
import { mapToScene, mapYawToScene } from '../frames.js';
import { RobotView, LABEL_ANCHOR } from './robot_view.js';
import { FleetInstances } from './fleet_instances.js';
import { LABEL_ASPECT, LABEL_BOTTOM, LabelAtlas } from './label_atlas.js';
import { FleetScans } from './fleet_scans.js';
import { labelOpacity } from '../label_rule.js';
import { DETAILED_MAX, nearestDetailed } from '../level_of_detail.js';
import { MapAnnotations } from './map_annotations.js';
import { formatSilence } from '../freshness.js';
import { displayName } from '../operator_names.js';
import { navLine } from '../nav_line.js';

/** Robots whose status is refreshed each frame, at least (a fleet of up to this many: all of them every frame). */
const STATUS_PER_FRAME = 12;

export class FleetView {
  /**
   * By robot name; the same Map for the life of the page (picking and the desktop controls hold it).
   * @type {Map<string, RobotView>}
   */
  views = new Map();

  /**
   * @param {THREE.Group} world @param {import('./gltf_loading.js').ModelLoader} loader
   * @param {THREE.WebGLRenderer} [renderer] uploads single label cells (without it, the whole atlas each time)
   * @param {number} [detailedMax] robots drawn with their full model at most (level_of_detail.js)
   */
  constructor(world, loader, renderer, detailedMax = DETAILED_MAX) {
    this.world = world;
    this.detailedMax = detailedMax;
    this.loader = loader;
    this.renderer = renderer ?? null;
    this.annotations = new MapAnnotations();
    world.add(this.annotations.group);
    this.instances = new FleetInstances(0);
    this.atlas = new LabelAtlas(0);
    this.scans = new FleetScans();
    world.add(this.instances.group, this.atlas.mesh, this.scans.points);
    /** Per robot (by index): the viewer's distance this frame (Infinity: not a candidate for the full model). */
    this.distances = new Float64Array(0);
    /** Each label's rectangle on the viewer's picture (x0, y0, x1, y1 px of the desktop's page or the headset's left
     * eye; NaN: not drawn) and its declutter factor (label_declutter.js): a label a more important one covers is a
     * ghost. */
    this.labelRects = new Float32Array(0);
    this.uncovered = new Float32Array(0);
    /** This frame's label heights (m) and distances (m), and the labels most important first: kept, not allocated
     * each frame. @type {number[]} */
    this.labelOrder = [];
    this.labelHeights = new Float64Array(0);
    this.labelFar = new Float64Array(0);
    /** @type {Set<number>} */
    this.detailed = new Set();
    /** @type {RobotView[]} by index */
    this.order = [];
    this.statusNext = 0;
    this.anchor = new THREE.Vector3();
  }

  /** A new fleet: every view and the shared parts are rebuilt. @param {import('../fleet_model.js').FleetModel} fleet */
  rebuild(fleet) {
    for (const view of this.views.values()) view.dispose();
    this.views.clear();
    this.instances.dispose();
    this.atlas.dispose();
    const n = fleet.robots.size;
    this.instances = new FleetInstances(n);
    this.atlas = new LabelAtlas(n);
    this.world.add(this.instances.group, this.atlas.mesh);
    this.distances = new Float64Array(n).fill(Infinity);
    this.labelRects = new Float32Array(4 * n).fill(NaN);
    this.uncovered = new Float32Array(n).fill(1);
    this.labelOrder = [...Array(n).keys()];
    this.labelHeights = new Float64Array(n);
    this.labelFar = new Float64Array(n);
    this.order = [];
    this.scans.changed = true;
    for (const entry of fleet.robots.values()) this.add(entry.description, this.order.length);
  }

  /**
   * One robot's model changed (the relay built it from its robot_description).
   * @param {import('../fleet_model.js').FleetModel} fleet @param {string} name
   */
  rebuildOne(fleet, name) {
    const entry = fleet.robots.get(name);
    const view = this.views.get(name);
    if (entry && view) this.add(entry.description, view.index);
  }

  /**
   * A robot's view, (re)built from its description (a new model replaces the old view, in the same place).
   * @param {import('../protocol.js').RobotDescription} description @param {number} index
   */
  add(description, index) {
    this.views.get(description.name)?.dispose();
    const view = new RobotView(description, this.loader, index, this.instances, this.atlas);
    this.views.set(description.name, view);
    this.order[index] = view;
    this.world.add(view.group);
  }

  /**
   * Place and label every robot for this frame.
   * @param {number} now
   * @param {{fleet: import('../fleet_model.js').FleetModel,
   *   smoothers: Map<string, import('../pose_smoother.js').PoseSmoother>,
   *   history: import('../sensor_history.js').SensorHistory, selected: string | null, eye: THREE.Vector3,
   *   freshness: import('../freshness.js').Freshness, link: 'live' | 'quiet' | 'lost', scans: boolean,
   *   pxPerRad: number, screen: {camera: THREE.Camera, width: number, height: number}}} state
   *   `link`: the relay answers, is silent on an open socket, or the socket is gone; `scans`: the operator's Scans
   *   switch; `pxPerRad`: the screen's pixels per radian (labels keep their lines legible on it); `screen`: the
   *   picture the labels are seen on, where those that would cover each other are decluttered: the desktop's camera
   *   and page, or in VR the XR camera (its left eye) and that eye's picture
   */
  update(now, { fleet, smoothers, history, selected, eye, freshness, link, scans, pxPerRad, screen }) {
    this.annotations.update(fleet);
    const t = fleet.scene.mapToScene;
    const n = this.order.length;
    // Statuses in turn: this frame's share of the fleet (all of a small fleet), from where the last frame stopped.
    const share = Math.max(STATUS_PER_FRAME, Math.ceil(n / 6));
    const first = n <= share ? 0 : this.statusNext;
    this.statusNext = n <= share ? 0 : (first + share) % n;
    for (let i = 0; i < n; i++) {
      const view = this.order[i];
      const entry = fleet.robots.get(view.name);
      if (!entry) continue;
      const pose = smoothers.get(view.name)?.sample(now);
      if (pose) {
        const [x, y, z] = mapToScene(t, pose.x, pose.y, 0);
        view.place(x, y, z, mapYawToScene(t, pose.yaw));
      }
      view.showScan(scans);
      view.ring.visible = view.name === selected;
      if (n <= share || (i - first + n) % n < share)
        this.#status(view, entry, fleet, history, selected, freshness, link, now);
      this.distances[i] = view.group.visible && view.hasModel ? eye.distanceTo(view.group.position) : Infinity;
    }
    nearestDetailed(this.distances, this.detailedMax, this.detailed);
    this.#labels(eye, pxPerRad, screen);
    for (let i = 0; i < n; i++) {
      const view = this.order[i];
      const shown = view.group.visible;
      view.setDetailed(this.detailed.has(i));
      this.instances.place(i, shown ? view.group.position : null, view.yaw, !view.detailed);
      this.anchor.copy(view.group.position).y += LABEL_ANCHOR;
      const opacity = labelOpacity(this.labelFar[i], view.keepLabel) * this.uncovered[i];
      this.atlas.place(i, shown ? this.anchor : null, this.labelHeights[i], opacity);
    }
    this.instances.placed();
    this.atlas.placed();
    this.atlas.flush(this.renderer, now);
    this.scans.update(this.order, scans, now);
  }

  /** The labels' order, most important first: a kept function, not a closure made each frame. */
  #importance = (/** @type {number} */ a, /** @type {number} */ b) =>
    Number(this.order[b].keepLabel) - Number(this.order[a].keepLabel) || this.labelFar[a] - this.labelFar[b];

  /**
   * Each label's distance and height (m) for this frame, and which labels are ghosts: their rectangles on the
   * viewer's picture, decluttered the selected robot's and a warning's first, then the nearest.
   * @param {THREE.Vector3} eye @param {number} pxPerRad
   * @param {{camera: THREE.Camera, width: number, height: number}} screen
   */
  #labels(eye, pxPerRad, screen) {
    const n = this.order.length;
    const { labelHeights: heights, labelFar: far, labelRects: rects, anchor } = this;
    const { camera, width, height } = screen;
    for (let i = 0; i < n; i++) {
      const view = this.order[i];
      const distance = eye.distanceTo(view.group.position);
      far[i] = distance;
      heights[i] = view.scaleLabel(distance, pxPerRad);
      rects[4 * i] = NaN;
      if (!view.group.visible || labelOpacity(distance, view.keepLabel) === 0) continue;
      // The quad as the label atlas draws it: in the camera's view space, facing it, above its anchor.
      anchor.copy(view.group.position).y += LABEL_ANCHOR;
      this.world.localToWorld(anchor).applyMatrix4(camera.matrixWorldInverse);
      const h = heights[i];
      const w = (h * LABEL_ASPECT) / 2;
      const bottom = anchor.y + LABEL_BOTTOM * h;
      const m = camera.projectionMatrix.elements;
      labelRect(m, anchor.x - w, bottom, anchor.x + w, bottom + h, anchor.z, width, height, rects, i);
    }
    this.labelOrder.sort(this.#importance);
    declutter(rects, this.labelOrder, this.uncovered);
  }

  /**
   * A robot's label and tint from its status and the link.
   * @param {RobotView} view @param {import('../fleet_model.js').RobotEntry} entry
   * @param {import('../fleet_model.js').FleetModel} fleet
   * @param {import('../sensor_history.js').SensorHistory} history @param {string | null} selected
   * @param {import('../freshness.js').Freshness} freshness @param {'live' | 'quiet' | 'lost'} link @param {number} now
   */
  #status(view, entry, fleet, history, selected, freshness, link, now) {
    const name = view.name;
    const status = entry.status;
    const controller = displayName(status?.controller, fleet.names, fleet.clientId);
    // Old news is never drawn as live: the whole fleet when the relay went quiet, a robot whose pose stopped.
    const silent = freshness.age(name, now);
    const since = silent !== null ? ` · ${formatSilence(silent)}` : '';
    const stale =
      link === 'lost'
        ? `connection lost${since}`
        : link === 'quiet'
          ? `relay silent${since}`
          : freshness.stale(name, now) && silent !== null
            ? `no pose for ${formatSilence(silent)}`
            : null;
    view.setStatus({
      name,
      mode: status?.mode ?? 'unknown',
      controller,
      offline: status ? !status.online : false,
      age: status?.age ?? null,
      selected: name === selected,
      warning: history.robotWarning(name),
      stale,
      nav: stale ? '' : navLine(entry.nav, status?.mode, now),
    });
  }

  dispose() {
    for (const view of this.views.values()) view.dispose();
    this.views.clear();
    this.instances.dispose();
    this.atlas.dispose();
    this.scans.dispose();
    this.annotations.dispose();
  }
}
