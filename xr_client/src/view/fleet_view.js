// @ts-check
/**
 * The robots in the twin: one RobotView per robot of the fleet, placed every frame from the smoothed poses
 * and labelled with their status. Views are rebuilt only when the fleet (or a robot's model) changes. The map's
 * annotations (room names, grid, north arrow) come with the fleet's hello and live here too.
 */
import * as THREE from 'three';
import { mapToScene, mapYawToScene } from '../frames.js';
import { RobotView } from './robot_view.js';
import { MapAnnotations } from './map_annotations.js';
import { formatSilence } from '../freshness.js';
import { displayName } from '../operator_names.js';

export class FleetView {
  /** By robot name; the same Map for the life of the page (picking and the desktop controls hold it). @type {Map<string, RobotView>} */
  views = new Map();

  /** @param {THREE.Group} world @param {import('./gltf_loading.js').ModelLoader} loader */
  constructor(world, loader) {
    this.world = world;
    this.loader = loader;
    this.annotations = new MapAnnotations();
    world.add(this.annotations.group);
  }

  /** A new fleet: every view is rebuilt. @param {import('../fleet_model.js').FleetModel} fleet */
  rebuild(fleet) {
    for (const view of this.views.values()) view.dispose();
    this.views.clear();
    for (const entry of fleet.robots.values()) this.add(entry.description);
  }

  /** One robot's model changed (the relay built it from its robot_description). @param {import('../fleet_model.js').FleetModel} fleet @param {string} name */
  rebuildOne(fleet, name) {
    const entry = fleet.robots.get(name);
    if (entry) this.add(entry.description);
  }

  /** A robot's view, (re)built from its description (a new model replaces the old view). @param {import('../protocol.js').RobotDescription} description */
  add(description) {
    this.views.get(description.name)?.dispose();
    const view = new RobotView(description, this.loader);
    this.views.set(description.name, view);
    this.world.add(view.group);
  }

  /**
   * Place and label every robot for this frame.
   * @param {number} now
   * @param {{fleet: import('../fleet_model.js').FleetModel, smoothers: Map<string, import('../pose_smoother.js').PoseSmoother>,
   *   history: import('../sensor_history.js').SensorHistory, selected: string | null, eye: THREE.Vector3,
   *   freshness: import('../freshness.js').Freshness, link: 'live' | 'quiet' | 'lost', scans: boolean}} state `link`: the
   *   relay answers, is silent on an open socket, or the socket is gone; `scans`: the operator's Scans switch
   */
  update(now, { fleet, smoothers, history, selected, eye, freshness, link, scans }) {
    this.annotations.update(fleet);
    const t = fleet.scene.mapToScene;
    for (const [name, view] of this.views) {
      const entry = fleet.robots.get(name);
      if (!entry) continue;
      const pose = smoothers.get(name)?.sample(now);
      if (pose) {
        const [x, y, z] = mapToScene(t, pose.x, pose.y, 0);
        view.place(x, y, z, mapYawToScene(t, pose.yaw));
        view.scaleLabel(eye.distanceTo(view.group.position));
      }
      view.showScan(scans);
      const status = entry.status;
      const controller = displayName(status?.controller, fleet.names, fleet.clientId);
      // Old news is never drawn as live: the whole fleet when the relay went quiet, a robot whose pose stopped.
      const silent = freshness.age(name, now);
      const since = silent !== null ? ` · ${formatSilence(silent)}` : '';
      const stale = link === 'lost' ? `connection lost${since}` : link === 'quiet' ? `relay silent${since}` : freshness.stale(name, now) && silent !== null ? `no pose for ${formatSilence(silent)}` : null;
      view.setStatus({
        name,
        mode: status?.mode ?? 'unknown',
        controller,
        offline: status ? !status.online : false,
        age: status?.age ?? null,
        selected: name === selected,
        warning: history.robotWarning(name),
        stale,
      });
    }
  }

  dispose() {
    for (const view of this.views.values()) view.dispose();
    this.views.clear();
    this.annotations.dispose();
  }
}
