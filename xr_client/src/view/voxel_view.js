// @ts-check
/**
 * The live 3D map drawn (issue #33): every voxel the model holds (voxel_map.js) as an instance of one box, in one
 * THREE.InstancedMesh, coloured per instance (the relay's RGB, else the height ramp): one draw call for the whole
 * map. Packing runs when a batch has come whole, at most every REPACK_MS, from a timer, never from the frame loop:
 * packing 100 000 voxels takes some 10 ms, a whole VR frame's budget. The capacity starts at FIRST_CAPACITY and
 * doubles when the map outgrows it, up to MAX_VOXELS (a map beyond that is drawn in part, and `clipped` says how
 * many are not).
 */
import * as THREE from 'three';

/** Instances the mesh first holds. */
const FIRST_CAPACITY = 16384;
/** Instances drawn at most: 262 144 boxes of 12 triangles are 3 M triangles, which a Quest-class GPU still draws. */
export const MAX_VOXELS = 262144;
/** Packs a second, at most: the relay sends a batch every 0.25 s at most. */
const REPACK_MS = 500;
/** A box slightly smaller than its voxel, so that neighbours read as a surface with seams, not one blob. */
const FILL = 0.92;

export class VoxelView {
  /**
   * @param {import('../voxel_map.js').VoxelMapModel} model
   * @param {() => import('../frames.js').MapToScene} transform where the map frame sits in the scene (hello)
   */
  constructor(model, transform) {
    this.model = model;
    this.transform = transform;
    this.group = new THREE.Group();
    this.group.name = 'voxel_map';
    this.material = new THREE.MeshLambertMaterial({ color: '#ffffff' });
    this.capacity = 0;
    this.voxel = 0;
    /** @type {THREE.InstancedMesh | null} */
    this.mesh = null;
    this.positions = new Float32Array(0);
    this.colours = new Float32Array(0);
    /** Voxels drawn now, and voxels held but not drawn (beyond MAX_VOXELS). */
    this.drawn = 0;
    this.clipped = 0;
    /** @type {ReturnType<typeof setTimeout> | null} */
    this.timer = null;
    this.lastPack = -Infinity;
  }

  /** Show or hide the map (the menu's `3D map`). @param {boolean} on */
  setVisible(on) {
    this.group.visible = on;
  }

  /** The model changed: pack it soon, once its batch is whole. */
  schedule() {
    if (this.timer !== null || !this.model.complete) return;
    const wait = Math.max(0, this.lastPack + REPACK_MS - performance.now());
    this.timer = setTimeout(() => {
      this.timer = null;
      this.pack();
    }, wait);
  }

  /** Pack every voxel into the instances. */
  pack() {
    const model = this.model;
    this.lastPack = performance.now();
    this.#fit(Math.min(model.count, MAX_VOXELS), model.voxel);
    const mesh = /** @type {THREE.InstancedMesh} */ (this.mesh);
    const n = model.pack(this.transform(), this.positions, this.colours, this.capacity);
    const matrices = mesh.instanceMatrix.array;
    for (let i = 0; i < n; i++) {
      // A translation alone: InstancedMesh starts every instance at the identity.
      matrices[16 * i + 12] = this.positions[3 * i];
      matrices[16 * i + 13] = this.positions[3 * i + 1];
      matrices[16 * i + 14] = this.positions[3 * i + 2];
    }
    mesh.count = n;
    mesh.instanceMatrix.needsUpdate = true;
    if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
    this.drawn = n;
    this.clipped = model.count - n;
  }

  /** A mesh of at least `count` instances of a box of `voxel` metres. @param {number} count @param {number} voxel */
  #fit(count, voxel) {
    if (this.mesh && count <= this.capacity && voxel === this.voxel) return;
    let capacity = Math.max(FIRST_CAPACITY, this.capacity);
    while (capacity < count) capacity *= 2;
    capacity = Math.min(capacity, MAX_VOXELS);
    this.#release();
    const size = voxel * FILL;
    const mesh = new THREE.InstancedMesh(new THREE.BoxGeometry(size, size, size), this.material, capacity);
    mesh.name = 'voxels';
    mesh.frustumCulled = false; // one mesh spans the site: culling it whole gains nothing
    // Pointing meets the map through the model's walk from voxel to voxel (view/picking.js), not three.js's test of
    // every instance (100 000 boxes, a frame's time).
    mesh.raycast = () => {};
    this.colours = new Float32Array(capacity * 3);
    mesh.instanceColor = new THREE.InstancedBufferAttribute(this.colours, 3);
    this.positions = new Float32Array(capacity * 3);
    this.mesh = mesh;
    this.capacity = capacity;
    this.voxel = voxel;
    this.group.add(mesh);
  }

  #release() {
    if (!this.mesh) return;
    this.group.remove(this.mesh);
    this.mesh.geometry.dispose();
    this.mesh.dispose();
    this.mesh = null;
  }

  dispose() {
    if (this.timer !== null) clearTimeout(this.timer);
    this.timer = null;
    this.#release();
    this.material.dispose();
  }
}
