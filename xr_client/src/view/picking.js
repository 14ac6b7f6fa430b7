// @ts-check
/**
 * What a ray meets: the twin's floor (for goals and teleports), a wall in the way, or a robot. Shared by the
 * desktop's mouse and the headset's pointers; it reads the twin and the robot views, and changes nothing.
 */
import * as THREE from 'three';
import { arcPoints } from '../arc.js';
import { mapToScene, sceneToMap } from '../frames.js';
import { goalVerdict, robotSpots } from '../goal_verdict.js';

export class Picking {
  /**
   * @param {import('./twin_view.js').TwinView} twin
   * @param {Map<string, import('./robot_view.js').RobotView>} robotViews
   * @param {import('../fleet_model.js').FleetModel} fleet for the map-to-scene transform
   * @param {import('./voxel_view.js').VoxelView} [voxels] the live 3D map, which pointing meets where it is shown
   */
  constructor(twin, robotViews, fleet, voxels) {
    this.twin = twin;
    this.voxels = voxels ?? null;
    this.robotViews = robotViews;
    this.fleet = fleet;
    this.raycaster = new THREE.Raycaster();
  }

  /**
   * What a pointer or a click may select a robot by: its model, and on the desktop its label too (sprites
   * need the raycaster's camera, which only the desktop's mouse ray has).
   * @param {boolean} [labels]
   */
  robotTargets(labels = false) {
    const views = [...this.robotViews.values()].filter((v) => v.group.visible);
    return labels ? views.flatMap((v) => [v.body, v.label.sprite]) : views.map((v) => v.body);
  }

  /**
   * The first thing of the twin or of the live 3D map a ray meets, of those shown (the menu's `Twin` and `3D map`:
   * an operator points at what they see), and whether it counts as floor. A goal or a teleport needs visible floor:
   * a wall in the way blocks it.
   * @param {THREE.Raycaster} raycaster
   * @returns {{point: THREE.Vector3, floor: boolean} | null}
   */
  pickTwin(raycaster) {
    const twin = this.twin.group.visible ? this.#twinHit(raycaster) : null;
    const voxels = this.#voxelHit(raycaster);
    const hit = voxels && (!twin || voxels.distance < twin.distance) ? voxels : twin;
    return hit && { point: hit.point, floor: hit.floor };
  }

  /**
   * The twin's: the `floor` node, or anything flat lying on it (a spill, a puddle), counts as floor.
   * @param {THREE.Raycaster} raycaster @returns {{point: THREE.Vector3, floor: boolean, distance: number} | null}
   */
  #twinHit(raycaster) {
    const content = this.twin.content;
    const hit = raycaster.intersectObjects(
      content ? [content, ...this.twin.floorTargets] : this.twin.floorTargets,
      true,
    )[0];
    if (!hit) return null;
    const floors = this.twin.floorTargets;
    let floor = false;
    for (let o = /** @type {THREE.Object3D | null} */ (hit.object); o && !floor; o = o.parent)
      floor = floors.includes(o);
    if (!floor && hit.face) {
      const up = hit.face.normal.clone().transformDirection(hit.object.matrixWorld).y;
      floor = up > 0.7 && hit.point.y <= this.twin.box.min.y + 0.1;
    }
    return { point: hit.point, floor, distance: hit.distance };
  }

  /**
   * The live 3D map's, walked voxel by voxel in the map frame (VoxelMapModel.raycast): the top of a voxel at most two
   * voxels above the map's floor (z = 0) counts as floor.
   * @param {THREE.Raycaster} raycaster @returns {{point: THREE.Vector3, floor: boolean, distance: number} | null}
   */
  #voxelHit(raycaster) {
    const view = this.voxels;
    if (!view || !view.group.visible || view.drawn === 0) return null;
    const t = this.fleet.scene.mapToScene;
    const { origin: o, direction: d } = raycaster.ray;
    const from = sceneToMap(t, o.x, o.y, o.z);
    const to = sceneToMap(t, o.x + d.x, o.y + d.y, o.z + d.z);
    const hit = view.model.raycast(from, [to[0] - from[0], to[1] - from[1], to[2] - from[2]], raycaster.far);
    if (!hit || hit.distance < raycaster.near) return null;
    const [x, y, z] = hit.point;
    const floor = hit.normal[2] > 0.5 && z <= 2 * view.model.voxel + 1e-6;
    return { point: new THREE.Vector3(...mapToScene(t, x, y, z)), floor, distance: hit.distance };
  }

  /**
   * The pointer arc from a hand to the floor (the twin's `floor` node, or the drawn floor); the arc ends at
   * whatever it meets first, and has no hit when that is not floor.
   * @param {THREE.Vector3} origin @param {THREE.Vector3} direction
   * @returns {{points: [number, number, number][], hit: THREE.Vector3 | null,
   *   surface: {point: THREE.Vector3, floor: boolean} | null}}
   *   `hit` the floor it lands on, `surface` whatever it meets first (a wall too: the pointer says why not)
   */
  arcToFloor(origin, direction) {
    return this.#along(
      arcPoints([origin.x, origin.y, origin.z], [direction.x, direction.y, direction.z], {
        floorY: this.#floorY() - 1,
        maxPoints: 64,
      }).points,
    );
  }

  /**
   * A straight ray to what it meets first (a gaze-and-pinch pointer: the goal is where the eyes are, not where an
   * arc thrown from them would land). Same shape as arcToFloor. @param {THREE.Vector3} origin
   * @param {THREE.Vector3} direction
   */
  rayToFloor(origin, direction) {
    const end = origin.clone().addScaledVector(direction.clone().normalize(), 30);
    return this.#along([
      /** @type {[number, number, number]} */ (origin.toArray()),
      /** @type {[number, number, number]} */ (end.toArray()),
    ]);
  }

  #floorY() {
    return this.twin.box.isEmpty() ? 0 : this.twin.box.min.y;
  }

  /** The first twin surface along a polyline, and the polyline cut there. @param {[number, number, number][]} points */
  #along(points) {
    const a = new THREE.Vector3();
    const b = new THREE.Vector3();
    for (let i = 1; i < points.length; i++) {
      a.fromArray(points[i - 1]);
      b.fromArray(points[i]);
      const length = a.distanceTo(b);
      this.raycaster.set(a, b.sub(a).normalize());
      this.raycaster.far = length;
      const hit = this.pickTwin(this.raycaster);
      if (hit)
        return {
          points: [...points.slice(0, i), /** @type {[number, number, number]} */ (hit.point.toArray())],
          hit: hit.floor ? hit.point : null,
          surface: hit,
        };
    }
    return { points, hit: null, surface: null };
  }

  /**
   * What a goal press would do where a pointer meets the twin (goal_verdict.js), and the map point it meets.
   * @param {{point: THREE.Vector3, floor: boolean} | null} surface @param {string | null} selected
   * @param {string | null} [holder] who holds the selected robot, when not this operator
   * @returns {{point: {x: number, y: number} | null, verdict: import('../goal_verdict.js').GoalVerdict}}
   */
  verdictAt(surface, selected, holder = null) {
    const point = surface ? this.sceneToMapPoint(surface.point) : null;
    const verdict = goalVerdict(point && surface ? { point, floor: surface.floor } : null, {
      robots: robotSpots(this.fleet),
      selected,
      bounds: this.fleet.bounds,
      holder,
    });
    return { point, verdict };
  }

  /**
   * Whether a scene point (x, z) is open floor in the twin: what a ray straight down over it meets first is floor.
   * @param {THREE.Vector3} p
   */
  isFloorAt(p) {
    const top = this.twin.box.isEmpty() ? 10 : this.twin.box.max.y + 10;
    this.raycaster.set(new THREE.Vector3(p.x, top, p.z), new THREE.Vector3(0, -1, 0));
    this.raycaster.far = Infinity;
    return this.pickTwin(this.raycaster)?.floor ?? false;
  }

  /** @param {THREE.Vector3} p a scene point @returns {{x: number, y: number}} */
  sceneToMapPoint(p) {
    const [x, y] = sceneToMap(this.fleet.scene.mapToScene, p.x, p.y, p.z);
    return { x, y };
  }
}
