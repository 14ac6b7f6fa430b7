// @ts-check
/**
 * The overview in VR: a tabletop miniature of the twin (a world in miniature) in front of the operator, with the
 * live robots on it as small arrows in their colours, and a cursor where a ray meets it. Pointing at it selects
 * robots, sets goals and teleports into the full-size twin (XRInteraction carries those out); this view maps a
 * ray's hit on it back to the map frame. The model shares the twin's materials, its geometry merged into one mesh
 * per material (merged_copy.js: the facility's 26 meshes were 26 more draw calls per eye, a clone of the node tree;
 * now 11); the robots' arrows are one InstancedMesh (one
 * draw call for the fleet: 100 robots were 100 meshes with a material each, 200 draw calls of a VR frame), moved
 * in place every frame, nothing is allocated per frame.
 */
import * as THREE from 'three';
import { disposeCopy, mergedCopy } from './merged_copy.js';
import { mapToScene, sceneToMap } from '../frames.js';
import { verdictColour } from '../goal_verdict.js';
import { TABLE_BEARING, TABLE_DISTANCE_M } from '../start_pose.js';

/** The miniature's longest side, metres: a table the operator reaches across standing still. */
const TABLE_SIZE = 0.8;
/** Where the table stands: its centre TABLE_DISTANCE_M from the head, TABLE_BEARING to the right of straight ahead
 * (start_pose.js keeps that spot free of walls), its top this far below the eyes (a standing operator's waist).
 * Straight ahead it stood in the way of every ray aimed at the floor within a few metres (the e2e test of the goal
 * arc caught it), and low ahead is the menu tab; front-left it was half behind the wrist panel (the left hand's):
 * front-right, nothing covers it, and the right hand points at it. */
const BELOW_EYES = 0.8;

export class MiniatureView {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'miniature';
    this.group.visible = false;
    /** The twin at scale, centred on the table's origin. */
    this.model = new THREE.Group();
    this.group.add(this.model);
    this.tableGeometry = new THREE.CylinderGeometry(1, 1, 1, 48);
    this.tableMaterial = new THREE.MeshBasicMaterial({ color: '#10151f', transparent: true, opacity: 0.85 });
    this.table = new THREE.Mesh(this.tableGeometry, this.tableMaterial);
    this.table.name = 'miniature-table';
    this.group.add(this.table);
    this.arrowGeometry = new THREE.ConeGeometry(0.5, 1.4, 12).rotateZ(-Math.PI / 2); // points along +x
    this.arrowMaterial = new THREE.MeshBasicMaterial({ color: '#ffffff' }); // times each robot's colour
    /** The arrows, one instance per robot (grown with the fleet). */
    this.arrows = this.#arrows(0);
    /** Robots shown by name -> instance; the colour each instance was given. @type {Map<string, number>} */
    this.robots = new Map();
    /** @type {string[]} */
    this.colours = [];
    this.matrix = new THREE.Matrix4();
    this.arrowPosition = new THREE.Vector3();
    this.arrowQuaternion = new THREE.Quaternion();
    // An arrow a robot's size would vanish at table scale: 0.8 m long in the twin's metres, 4 cm on the table.
    this.arrowScale = new THREE.Vector3(0.6, 0.6, 0.6);
    this.up = new THREE.Vector3(0, 1, 0);
    this.cursorGeometry = new THREE.RingGeometry(0.6, 1, 24).rotateX(-Math.PI / 2);
    this.cursorMaterial = new THREE.MeshBasicMaterial({ color: '#ffffff', side: THREE.DoubleSide, depthTest: false });
    this.cursor = new THREE.Mesh(this.cursorGeometry, this.cursorMaterial);
    this.cursor.renderOrder = 25;
    this.cursor.visible = false;
    this.cursor.raycast = () => {};
    this.model.add(this.cursor);
    /** Scene units per miniature unit's inverse: model = (scene - centre) * scale. */
    this.scale = 1;
    this.centre = new THREE.Vector3();
    /** The twin content the model was cloned from (rebuilt when the twin changes). @type {THREE.Object3D | null} */
    this.source = null;
    /** @type {THREE.Object3D | null} */
    this.copy = null;
    this.floorY = 0;
    this.inverse = new THREE.Matrix4();
    /** The full-size 3D map's mesh the table mirrors, and its mirror. @type {THREE.InstancedMesh | null} */
    this.mapSource = null;
    /** @type {THREE.InstancedMesh | null} */
    this.mapMirror = null;
  }

  /**
   * Follow the twin: a new scene (or the first one) is cloned at table scale.
   * @param {import('./twin_view.js').TwinView} twin
   */
  setTwin(twin) {
    if (twin.content === this.source) return;
    this.source = twin.content;
    this.#dropCopy();
    if (!twin.content) return;
    const box = new THREE.Box3().setFromObject(twin.content);
    if (box.isEmpty()) return;
    const size = box.getSize(new THREE.Vector3());
    this.scale = TABLE_SIZE / Math.max(size.x, size.z, 1);
    box.getCenter(this.centre);
    this.floorY = twin.box.isEmpty() ? box.min.y : twin.box.min.y;
    this.centre.y = this.floorY;
    this.copy = mergedCopy(twin.content);
    this.model.add(this.copy);
    this.model.scale.setScalar(this.scale);
    this.model.position.copy(this.centre).multiplyScalar(-this.scale);
    const radius = Math.hypot(size.x, size.z) * this.scale * 0.55;
    this.table.scale.set(radius, 0.02, radius);
    this.table.position.set(0, -0.011, 0);
  }

  /**
   * The live 3D map on the table too (issue #33), drawn from the full-size map's own instances: one more draw call,
   * its matrices and colours shared, nothing copied or packed again. The twin's copy hides when the twin does, so
   * that the table shows what the full-size view shows.
   * @param {import('./voxel_view.js').VoxelView} voxels @param {boolean} twinShown
   */
  follow(voxels, twinShown) {
    if (this.copy) this.copy.visible = twinShown;
    const source = voxels.group.visible && this.copy ? voxels.mesh : null;
    if (source !== this.mapSource) {
      this.mapMirror?.removeFromParent();
      this.mapMirror = null;
      this.mapSource = source;
      if (source) {
        const mirror = new THREE.InstancedMesh(source.geometry, source.material, source.instanceMatrix.count);
        mirror.instanceMatrix = source.instanceMatrix;
        mirror.instanceColor = source.instanceColor;
        mirror.name = 'miniature-voxels';
        mirror.frustumCulled = false;
        mirror.raycast = () => {}; // the table is read as a map: a ray meets its floor plane
        this.model.add(mirror);
        this.mapMirror = mirror;
      }
    }
    if (this.mapMirror && source) this.mapMirror.count = source.count;
  }

  /**
   * Move the robots' arrows to where the full-size robots are drawn (their smoothed poses) and show the cursor.
   * @param {Map<string, import('./robot_view.js').RobotView>} views
   * @param {{x: number, y: number} | null} cursor a map point the pointer aims at on the table, or none
   * @param {import('../goal_verdict.js').GoalVerdict | null} verdict what a press there would do
   * @param {import('../frames.js').MapToScene} transform
   */
  update(views, cursor, verdict, transform) {
    if (!this.group.visible) return;
    if (views.size > this.arrows.instanceMatrix.count) {
      this.arrows.removeFromParent();
      this.arrows.dispose();
      this.arrows = this.#arrows(Math.max(views.size, 2 * this.arrows.instanceMatrix.count));
      this.colours = [];
    }
    this.robots.clear();
    let i = 0;
    for (const [name, view] of views) {
      this.robots.set(name, i);
      const hex = view.colour.getHexString();
      if (this.colours[i] !== hex) {
        this.colours[i] = hex;
        this.arrows.setColorAt(i, view.colour);
        /** @type {THREE.InstancedBufferAttribute} */ (this.arrows.instanceColor).needsUpdate = true;
      }
      this.arrowPosition.copy(view.group.position);
      this.arrowPosition.y = this.floorY + 0.3;
      this.arrowQuaternion.setFromAxisAngle(this.up, view.yaw);
      this.matrix.compose(this.arrowPosition, this.arrowQuaternion, this.arrowScale);
      if (!view.group.visible) this.matrix.makeScale(0, 0, 0);
      this.arrows.setMatrixAt(i++, this.matrix);
    }
    this.arrows.count = i;
    this.arrows.instanceMatrix.needsUpdate = true;
    this.cursor.visible = cursor !== null;
    if (cursor) {
      const [x, y, z] = mapToScene(transform, cursor.x, cursor.y, 0);
      this.cursor.position.set(x, y + 0.15, z);
      this.cursor.scale.setScalar(0.5);
      this.cursorMaterial.color.set(verdictColour(verdict));
    }
  }

  #dropCopy() {
    disposeCopy(this.copy);
    this.copy = null;
  }

  /** An InstancedMesh for `n` arrows, on the model. @param {number} n */
  #arrows(n) {
    const arrows = new THREE.InstancedMesh(this.arrowGeometry, this.arrowMaterial, Math.max(1, n));
    arrows.name = 'miniature-robots';
    arrows.count = 0;
    arrows.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    arrows.frustumCulled = false; // instances move: a bounding sphere computed once would cull them wrongly
    arrows.raycast = () => {}; // the table is read as a map: a ray meets its floor, not the arrows
    this.model.add(arrows);
    return arrows;
  }

  /** Put the table front-right of the operator, level, its north the twin's north. @param {THREE.Camera} camera */
  place(camera) {
    const head = camera.getWorldPosition(new THREE.Vector3());
    const forward = camera.getWorldDirection(new THREE.Vector3());
    forward.y = 0;
    if (forward.lengthSq() < 1e-6) forward.set(0, 0, -1);
    // Scene yaw turns counter-clockwise seen from above, as the map's does: a negative bearing is to the right.
    forward.normalize().applyAxisAngle(new THREE.Vector3(0, 1, 0), TABLE_BEARING);
    this.group.position.copy(head).addScaledVector(forward, TABLE_DISTANCE_M);
    this.group.position.y = head.y - BELOW_EYES;
    this.group.updateMatrixWorld(true);
  }

  /** What a ray may meet on the table (the model's meshes; the table top counts as off the map). */
  pickables() {
    return this.group.visible && this.copy ? [this.copy] : [];
  }

  /** Whether a hit object is part of the miniature. @param {THREE.Object3D} object */
  owns(object) {
    for (let o = /** @type {THREE.Object3D | null} */ (object); o; o = o.parent) if (o === this.group) return true;
    return false;
  }

  /**
   * Where a ray pointing at the table points in the full-size twin: the ray meets the miniature's floor plane (not
   * the first wall it grazes: the table is read as a map, and a robot just behind a miniature wall is still
   * pointed at), taken back to the twin's scene and the map frame.
   * @param {THREE.Vector3} origin @param {THREE.Vector3} direction the ray, world frame
   * @param {import('../frames.js').MapToScene} transform
   * @returns {{point: {x: number, y: number}, scene: THREE.Vector3} | null} null when it points away from it
   */
  toTwin(origin, direction, transform) {
    this.model.updateWorldMatrix(true, false);
    this.inverse.copy(this.model.matrixWorld).invert();
    const o = origin.clone().applyMatrix4(this.inverse);
    const d = direction.clone().transformDirection(this.inverse);
    if (d.y >= -1e-6) return null;
    const t = (this.floorY - o.y) / d.y;
    if (t <= 0) return null;
    const scene = o.addScaledVector(d, t);
    const [x, y] = sceneToMap(transform, scene.x, scene.y, scene.z);
    return { point: { x, y }, scene };
  }

  /**
   * Where a map point is on the table, in the world (tests aim the emulated controllers there).
   * @param {number} x @param {number} y @param {import('../frames.js').MapToScene} transform
   */
  worldPoint(x, y, transform) {
    this.model.updateWorldMatrix(true, false);
    const [sx, sy, sz] = mapToScene(transform, x, y, 0);
    return this.model.localToWorld(new THREE.Vector3(sx, sy, sz)).toArray();
  }

  dispose() {
    this.#dropCopy();
    this.group.removeFromParent();
    this.tableGeometry.dispose();
    this.tableMaterial.dispose();
    this.arrows.dispose();
    this.arrowGeometry.dispose();
    this.arrowMaterial.dispose();
    this.cursorGeometry.dispose();
    this.cursorMaterial.dispose();
  }
}
