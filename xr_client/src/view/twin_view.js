// @ts-check
/**
 * The facility twin: the scene glTF announced in `hello` (and later `scene` messages), or, when its URL is
 * null, a floor drawn from `hello.bounds`. Exposes the objects a pointer may land on (`floorTargets`):
 * the glTF node named `floor`, else the drawn floor, else an infinite plane at y = 0.
 */
import * as THREE from 'three';
import { mapToScene } from '../frames.js';
import { disposeCopy, mergedCopy } from './merged_copy.js';

export class TwinView {
  /** @param {{load: import('./gltf_loading.js').ModelLoader['load'], release: (url: string) => void}} loader */
  constructor(loader) {
    this.loader = loader;
    this.group = new THREE.Group();
    this.group.name = 'twin';
    /** @type {THREE.Object3D | null} */
    this.content = null;
    /** What is drawn of a loaded twin: its meshes merged by material (merged_copy.js). @type {THREE.Object3D | null} */
    this.drawn = null;
    /** @type {THREE.Object3D[]} */
    this.floorTargets = [];
    /** @type {string | null | undefined} */
    this.url = undefined;
    this.boundsKey = '';
    this.generation = 0;
    /** @type {'none' | 'loading' | 'loaded' | 'floor' | 'failed'} */
    this.state = 'none';
    this.error = '';
    /** Scene-space box of the floor, for the desktop camera. */
    this.box = new THREE.Box3(new THREE.Vector3(-5, 0, -5), new THREE.Vector3(5, 0, 5));
    const fallbackGeometry = new THREE.PlaneGeometry(2000, 2000).rotateX(-Math.PI / 2);
    this.fallbackPlane = new THREE.Mesh(fallbackGeometry, new THREE.MeshBasicMaterial({ visible: false }));
    this.fallbackPlane.name = 'floor';
    this.group.add(this.fallbackPlane);
  }

  /**
   * Show a scene: its glTF, or the floor from the bounds when the URL is null. Reloads only on change.
   * @param {import('../fleet_model.js').Scene} scene @param {number[] | null} bounds
   */
  setScene(scene, bounds) {
    const boundsKey = JSON.stringify([bounds, scene.mapToScene]);
    if (scene.url === this.url && (scene.url !== null || boundsKey === this.boundsKey)) return;
    // The replaced twin is gone for good (a twin URL names one version of one map): free it.
    if (this.url && this.url !== scene.url) this.loader.release(this.url);
    this.url = scene.url;
    this.boundsKey = boundsKey;
    const generation = ++this.generation;
    this.#clear();
    if (scene.url) {
      this.state = 'loading';
      this.loader.load(scene.url).then(
        (gltf) => {
          if (generation !== this.generation) return; // a newer scene replaced this one meanwhile
          const content = gltf.scene.clone(true);
          this.#show(content);
          const floor = content.getObjectByName('floor');
          this.floorTargets = floor ? [floor] : [this.fallbackPlane];
          this.box.setFromObject(floor ?? content);
          this.state = 'loaded';
        },
        (error) => {
          if (generation !== this.generation) return;
          console.warn(`twin ${scene.url} could not be loaded; drawing the floor from the bounds`, error);
          this.state = 'failed';
          this.error = String(error?.message ?? error);
          this.#drawFloor(bounds, scene.mapToScene);
        },
      );
    } else {
      this.#drawFloor(bounds, scene.mapToScene);
    }
  }

  /**
   * @param {number[] | null} bounds @param {import('../frames.js').MapToScene} transform
   */
  #drawFloor(bounds, transform) {
    const [minX, minY, maxX, maxY] = bounds ?? [-10, -10, 10, 10];
    const w = maxX - minX;
    const h = maxY - minY;
    const content = new THREE.Group();
    content.name = 'drawn-floor';
    // Built in the map frame (ROS x east, y north), then placed by map_to_scene.
    const geometry = new THREE.PlaneGeometry(w, h).rotateX(-Math.PI / 2);
    const material = new THREE.MeshStandardMaterial({ color: '#3b4252', roughness: 0.95 });
    const floor = new THREE.Mesh(geometry, material);
    floor.name = 'floor';
    floor.position.set(minX + w / 2, 0, -(minY + h / 2));
    content.add(floor);
    const grid = [];
    for (let x = Math.ceil(minX); x <= maxX; x++) grid.push(x, 0.002, -minY, x, 0.002, -maxY);
    for (let y = Math.ceil(minY); y <= maxY; y++) grid.push(minX, 0.002, -y, maxX, 0.002, -y);
    const gridGeometry = new THREE.BufferGeometry();
    gridGeometry.setAttribute('position', new THREE.Float32BufferAttribute(grid, 3));
    const lines = new THREE.LineSegments(gridGeometry, new THREE.LineBasicMaterial({ color: '#56607a' }));
    lines.raycast = () => {};
    content.add(lines);
    const edge = new THREE.LineLoop(
      new THREE.BufferGeometry().setFromPoints([
        new THREE.Vector3(minX, 0.004, -minY),
        new THREE.Vector3(maxX, 0.004, -minY),
        new THREE.Vector3(maxX, 0.004, -maxY),
        new THREE.Vector3(minX, 0.004, -maxY),
      ]),
      new THREE.LineBasicMaterial({ color: '#c9d1e0' }),
    );
    edge.raycast = () => {};
    content.add(edge);
    const [ox, oy, oz] = mapToScene(transform, 0, 0, 0);
    content.position.set(ox, oy, oz);
    content.rotation.y = transform.yaw;
    this.#show(content);
    content.updateMatrixWorld(true);
    this.floorTargets = [floor];
    this.box.setFromObject(floor);
    this.state = 'floor';
  }

  /** @param {THREE.Object3D} content */
  #show(content) {
    this.content = content;
    this.group.add(content);
    if (content.name === 'drawn-floor') return;
    // Drawn merged by material (merged_copy.js); the loaded nodes stay, hidden, for picking and bounds.
    this.drawn = mergedCopy(content);
    this.group.add(this.drawn);
    content.visible = false;
  }

  #clear() {
    disposeCopy(this.drawn);
    this.drawn = null;
    if (!this.content) return;
    this.content.removeFromParent();
    // Drawn floors own their geometry; a glTF's resources stay cached in the loader for a reload.
    if (this.content.name === 'drawn-floor') disposeTree(this.content);
    this.content = null;
    this.floorTargets = [this.fallbackPlane];
  }

  dispose() {
    this.generation++;
    this.#clear();
    this.fallbackPlane.geometry.dispose();
    /** @type {THREE.Material} */ (this.fallbackPlane.material).dispose();
    this.group.removeFromParent();
  }
}

/** @param {THREE.Object3D} root */
export function disposeTree(root) {
  root.traverse((object) => {
    const mesh = /** @type {THREE.Mesh} */ (object);
    mesh.geometry?.dispose();
    const material = mesh.material;
    if (Array.isArray(material)) material.forEach((m) => m.dispose());
    else material?.dispose();
  });
}
