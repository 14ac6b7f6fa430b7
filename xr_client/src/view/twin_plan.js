// @ts-check
/**
 * The twin as a floor plan, for where VR starts (start_pose.js): its triangles taken into the map frame and cut at a
 * standing operator's heights into walls, a grid of the room around every point, and whether a point is the twin's
 * floor (Picking: a ray down meets the floor first). Built once per twin (a new scene builds it again) when VR is
 * entered; ~0.1 s for the demo facility's 2 300 triangles on a loaded 2-core machine, nothing per frame.
 */
import * as THREE from 'three';
import { mapToScene, sceneToMap } from '../frames.js';
import { WALL_HEIGHTS_M, roomGrid, sliceWalls, startPose } from '../start_pose.js';

export class TwinPlan {
  /**
   * @param {import('./twin_view.js').TwinView} twin @param {import('./picking.js').Picking} picking
   * @param {import('../fleet_model.js').FleetModel} fleet the map's bounds, rooms, robots and map-to-scene transform
   */
  constructor(twin, picking, fleet) {
    this.twin = twin;
    this.picking = picking;
    this.fleet = fleet;
    /**
     * The twin content and bounds the grid was built from. @type {{content: THREE.Object3D | null, key: string} | null}
     */
    this.built = null;
    /** @type {import('../start_pose.js').RoomGrid | null} */
    this.grid = null;
    /** The last start chosen, for the state snapshot. @type {import('../start_pose.js').StartPose | null} */
    this.last = null;
  }

  /**
   * Where to start now (map frame), or null while the twin is loading, without bounds, or with no spot to stand on.
   * @returns {import('../start_pose.js').StartPose | null}
   */
  start() {
    const grid = this.#grid();
    if (!grid) return null;
    const t = this.fleet.scene.mapToScene;
    const point = new THREE.Vector3();
    const robots = [...this.fleet.robots.values()]
      .filter((r) => r.pose)
      .map((r) => ({
        name: r.description.name,
        x: /** @type {{x: number}} */ (r.pose).x,
        y: /** @type {{y: number}} */ (r.pose).y,
      }));
    const floor = (/** @type {number} */ x, /** @type {number} */ y) =>
      this.picking.isFloorAt(point.fromArray(mapToScene(t, x, y, 0)));
    const rooms = this.fleet.rooms.map((r) => ({ name: r.name, bounds: r.bounds }));
    this.last = startPose({ grid, robots, rooms, floor });
    // A twin whose every spot reads as something other than floor (a roof over it: the rays down meet it first).
    if (!this.last) this.last = startPose({ grid, robots, rooms });
    return this.last;
  }

  /** The room grid of the twin shown now, built when the twin or the bounds changed. */
  #grid() {
    const twin = this.twin;
    if (twin.state === 'loading' || twin.state === 'none') return null;
    const bounds = this.fleet.bounds ?? this.#boundsOfTwin();
    if (!bounds) return null;
    const key = JSON.stringify([bounds, this.fleet.scene.mapToScene]);
    if (this.built?.content === twin.content && this.built.key === key) return this.grid;
    this.built = { content: twin.content, key };
    this.grid = roomGrid(sliceWalls(this.#triangles(), this.#heights()), bounds);
    return this.grid;
  }

  /** The twin's triangles in the map frame (x, y, z up), 9 numbers each. */
  #triangles() {
    const content = this.twin.content;
    /** @type {number[]} */
    const out = [];
    if (!content) return out;
    content.updateMatrixWorld(true);
    const t = this.fleet.scene.mapToScene;
    const v = new THREE.Vector3();
    content.traverse((object) => {
      const mesh = /** @type {THREE.Mesh} */ (object);
      const position = mesh.isMesh ? mesh.geometry?.getAttribute('position') : null;
      if (!position) return;
      const index = mesh.geometry.index;
      const n = index ? index.count : position.count;
      for (let k = 0; k < n; k++) {
        v.fromBufferAttribute(/** @type {THREE.BufferAttribute} */ (position), index ? index.getX(k) : k).applyMatrix4(
          mesh.matrixWorld,
        );
        out.push(...sceneToMap(t, v.x, v.y, v.z));
      }
    });
    return out;
  }

  /** The planes' heights in the map frame: over the twin's floor. */
  #heights() {
    const box = this.twin.box;
    const floorY = box.isEmpty() ? 0 : box.min.y;
    const floorZ = sceneToMap(
      this.fleet.scene.mapToScene,
      box.isEmpty() ? 0 : box.getCenter(new THREE.Vector3()).x,
      floorY,
      0,
    )[2];
    return WALL_HEIGHTS_M.map((h) => floorZ + h);
  }

  /** The twin's floor box in the map frame, when hello gave no bounds. @returns {number[] | null} */
  #boundsOfTwin() {
    const box = this.twin.box;
    if (box.isEmpty()) return null;
    const t = this.fleet.scene.mapToScene;
    const corners = [
      [box.min.x, box.min.z],
      [box.min.x, box.max.z],
      [box.max.x, box.min.z],
      [box.max.x, box.max.z],
    ].map(([x, z]) => sceneToMap(t, x, box.min.y, z));
    const xs = corners.map((c) => c[0]);
    const ys = corners.map((c) => c[1]);
    return [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
  }
}
