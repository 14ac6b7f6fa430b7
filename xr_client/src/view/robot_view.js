// @ts-check
/**
 * One robot in the twin: its model (the glTF from `hello`, or a built-in shape when the model is ""),
 * tinted with its colour through the material named `body`; a footprint on the floor with a heading arrow (the
 * robot's +x, readable from above at any distance); a label (name, mode, controller) that keeps about the same
 * size on screen within limits; a red warning icon visible from anywhere; a selection ring; laser scan points in
 * the robot frame (shown unless the operator turns scans off). Offline, the robot is greyed and its label shows
 * the age of its data. The view only reads the fleet model.
 */
import * as THREE from 'three';
import { adoptMaterials } from './model_materials.js';
import { LabelSprite, WarningSprite } from './label_sprite.js';
import { MAX_SCAN_POINTS, scanToPoints } from '../scan.js';

const GREY = new THREE.Color('#777777');
/** A label's height on screen, as an angle (rad): ~2 degrees, 27 px in a 60-degree desktop view 800 px high,
 * ~40 px on a Quest 3. Within LABEL_MIN..LABEL_MAX metres: not a wall of text up close (it was 0.26 m whatever
 * the distance under 5 m, larger than the robot), not a billboard across the site. */
export const LABEL_ANGLE = 0.035;
export const LABEL_MIN = 0.07;
export const LABEL_MAX = 1.5;
/** Where labels hang from: the top of a TurtleBot-sized robot (m). */
const LABEL_ANCHOR = 0.45;
/** The footprint's radius (m): a TurtleBot-sized base, the built-in shape's 0.2 m and a margin. */
const FOOTPRINT = 0.26;

export class RobotView {
  /**
   * @param {import('../fleet_model.js').RobotDescription} description
   * @param {import('./gltf_loading.js').ModelLoader} loader
   */
  constructor(description, loader) {
    this.name = description.name;
    this.colour = new THREE.Color(description.colour);
    this.group = new THREE.Group();
    this.group.name = `robot:${description.name}`;
    this.group.userData.robot = description.name;
    this.group.visible = false; // until its first pose
    /** Holds the model: replaced when a glTF arrives. */
    this.body = new THREE.Group();
    this.group.add(this.body);
    /** @type {THREE.Material[]} materials owned by this view */
    this.materials = [];
    /** @type {THREE.BufferGeometry[]} */
    this.geometries = [];
    this.#builtin(description.cameras.length > 0);
    this.loadGeneration = 0;
    if (description.model) this.#loadModel(description.model, loader);

    // On top of walls: the operator keeps track of every robot (an x-ray view of the twin).
    this.label = new LabelSprite({ width: 512, height: 150, worldHeight: 0.26, onTop: true });
    // Anchored at the robot's top and drawn above that point on screen (sprite centre below the label): seen from
    // above, the label sits beside the robot instead of on it, and its footprint and heading stay visible.
    this.label.sprite.position.set(0, LABEL_ANCHOR, 0);
    this.label.sprite.center.set(0.5, -0.35);
    this.label.sprite.userData.robot = description.name;
    this.group.add(this.label.sprite);
    this.warning = new WarningSprite();
    // Above the label: the icon is 0.05 of the view high (sizeAttenuation off), the label LABEL_ANGLE, ~1.4 times
    // less; a centre 1.05 icons below it clears the label's top (0.35 + 1 label heights up).
    this.warning.sprite.position.set(0, LABEL_ANCHOR, 0);
    this.warning.sprite.center.set(0.5, -1.05);
    this.warning.sprite.visible = false;
    this.group.add(this.warning.sprite);

    /** The footprint and heading arrow, turned with the robot. */
    this.heading = new THREE.Group();
    /** @type {THREE.MeshBasicMaterial[]} */
    this.footprintMaterials = [];
    this.#footprint();

    const ringGeometry = new THREE.RingGeometry(0.32, 0.38, 48).rotateX(-Math.PI / 2);
    const ringMaterial = new THREE.MeshBasicMaterial({ color: '#ffffff', transparent: true, opacity: 0.85 });
    this.ring = new THREE.Mesh(ringGeometry, ringMaterial);
    this.ring.position.y = 0.01;
    this.ring.visible = false;
    this.ring.raycast = () => {};
    this.group.add(this.ring);
    this.geometries.push(ringGeometry);
    this.materials.push(ringMaterial);

    this.scanPositions = new Float32Array(MAX_SCAN_POINTS * 3);
    this.scanXY = new Float32Array(MAX_SCAN_POINTS * 2);
    const scanGeometry = new THREE.BufferGeometry();
    scanGeometry.setAttribute('position', new THREE.BufferAttribute(this.scanPositions, 3).setUsage(THREE.DynamicDrawUsage));
    scanGeometry.setDrawRange(0, 0);
    // A few pixels whatever the distance (as RViz draws points): 6 cm dots were invisible from across the site.
    const scanMaterial = new THREE.PointsMaterial({ color: this.colour, size: 3.5, sizeAttenuation: false });
    this.scan = new THREE.Points(scanGeometry, scanMaterial);
    this.scan.frustumCulled = false;
    this.scan.raycast = () => {};
    this.group.add(this.scan);
    this.geometries.push(scanGeometry);
    this.materials.push(scanMaterial);
    this.offline = false;
    /** Why what this view shows is old (the link, the pose), or null while it is live. @type {string | null} */
    this.stale = null;
  }

  /** The footprint and the heading arrow: flat on the floor, turned with the robot (see place()). */
  #footprint() {
    this.heading.name = `footprint:${this.name}`;
    const discGeometry = new THREE.CircleGeometry(FOOTPRINT, 40).rotateX(-Math.PI / 2);
    const edgeGeometry = new THREE.RingGeometry(FOOTPRINT - 0.025, FOOTPRINT, 40).rotateX(-Math.PI / 2);
    // The arrow points along +x (the robot's forward) from the footprint's edge: 0.45 m long, so that the heading
    // reads from 20 m away, where the robot itself is a dozen pixels.
    const arrow = new THREE.Shape();
    arrow.moveTo(FOOTPRINT + 0.45, 0);
    arrow.lineTo(FOOTPRINT - 0.02, 0.16);
    arrow.lineTo(FOOTPRINT + 0.08, 0);
    arrow.lineTo(FOOTPRINT - 0.02, -0.16);
    arrow.closePath();
    const arrowGeometry = new THREE.ShapeGeometry(arrow).rotateX(-Math.PI / 2);
    const fill = new THREE.MeshBasicMaterial({ color: this.colour, transparent: true, opacity: 0.28, depthWrite: false });
    const solid = new THREE.MeshBasicMaterial({ color: this.colour, transparent: true, opacity: 0.95, depthWrite: false });
    const parts = [new THREE.Mesh(discGeometry, fill), new THREE.Mesh(edgeGeometry, solid), new THREE.Mesh(arrowGeometry, solid)];
    parts.forEach((mesh, i) => {
      mesh.position.y = 0.012 + i * 0.002; // above the floor, below the selection ring
      mesh.raycast = () => {};
      mesh.renderOrder = 2;
      this.heading.add(mesh);
    });
    this.footprintMaterials = [fill, solid];
    this.group.add(this.heading);
    this.geometries.push(discGeometry, edgeGeometry, arrowGeometry);
    this.materials.push(fill, solid);
  }

  /** @param {boolean} hasCamera */
  #builtin(hasCamera) {
    // A TurtleBot-sized base: 0.4 m round, forward along +x like the robot frame.
    const bodyGeometry = new THREE.CylinderGeometry(0.2, 0.2, 0.22, 32).translate(0, 0.13, 0);
    const body = new THREE.MeshStandardMaterial({ name: 'body', color: this.colour, roughness: 0.6 });
    const trimGeometry = new THREE.BoxGeometry(0.12, 0.06, 0.24).translate(0.14, 0.27, 0);
    const trim = new THREE.MeshStandardMaterial({ color: '#222831', roughness: 0.8 });
    /** @type {THREE.Mesh[]} */
    const meshes = [new THREE.Mesh(bodyGeometry, body), new THREE.Mesh(trimGeometry, trim)];
    this.geometries.push(bodyGeometry, trimGeometry);
    this.materials.push(body, trim);
    if (hasCamera) {
      const camGeometry = new THREE.SphereGeometry(0.05, 16, 12).translate(0.16, 0.33, 0);
      const cam = new THREE.MeshStandardMaterial({ color: '#0b0d12', roughness: 0.2, metalness: 0.5 });
      meshes.push(new THREE.Mesh(camGeometry, cam));
      this.geometries.push(camGeometry);
      this.materials.push(cam);
    }
    for (const mesh of meshes) {
      mesh.userData.robot = this.name;
      this.body.add(mesh);
    }
  }

  /**
   * @param {string} url @param {import('./gltf_loading.js').ModelLoader} loader
   */
  async #loadModel(url, loader) {
    const generation = ++this.loadGeneration;
    try {
      const gltf = await loader.load(url);
      if (generation !== this.loadGeneration || this.disposed) return; // a newer load or a dispose won
      const model = gltf.scene.clone(true);
      model.traverse((object) => {
        object.userData.robot = this.name;
      });
      this.materials.push(...adoptMaterials(model, this.colour));
      this.body.clear();
      this.body.add(model);
      this.#applyTint();
    } catch (error) {
      console.warn(`robot ${this.name}: model ${url} could not be loaded; keeping the built-in shape`, error);
    }
  }

  /**
   * The label keeps about the same size on screen (LABEL_ANGLE), within LABEL_MIN..LABEL_MAX metres.
   * @param {number} distance from the viewer, metres
   */
  scaleLabel(distance) {
    const h = Math.min(LABEL_MAX, Math.max(LABEL_MIN, LABEL_ANGLE * distance));
    this.label.sprite.scale.set((h * this.label.canvas.width) / this.label.canvas.height, h, 1);
  }

  /** Show or hide the laser scan (the operator's Scans switch). @param {boolean} on */
  showScan(on) {
    this.scan.visible = on;
  }

  /**
   * Place the robot (scene coordinates, yaw about +y).
   * @param {number} x @param {number} y @param {number} z @param {number} yaw
   */
  place(x, y, z, yaw) {
    this.group.visible = true;
    this.group.position.set(x, y, z);
    this.body.rotation.y = yaw;
    this.scan.rotation.y = yaw;
    this.heading.rotation.y = yaw;
  }

  /** @param {boolean} offline */
  setOffline(offline) {
    if (offline === this.offline) return;
    this.offline = offline;
    this.#applyTint();
  }

  /** Grey and fade the model while offline; restore its own colours when back. */
  #applyTint() {
    const offline = this.offline;
    this.body.traverse((object) => {
      const mesh = /** @type {THREE.Mesh} */ (object);
      if (!mesh.isMesh) return;
      for (const m of Array.isArray(mesh.material) ? mesh.material : [mesh.material]) {
        const material = /** @type {THREE.MeshStandardMaterial} */ (m);
        if (!material.color) continue;
        if (material.userData.colour === undefined) material.userData.colour = material.color.getHex();
        material.color.setHex(material.userData.colour);
        if (offline) material.color.lerp(GREY, 0.8);
        material.transparent = offline;
        material.opacity = offline ? 0.55 : 1;
      }
    });
    for (const material of this.footprintMaterials) material.color.copy(this.colour).lerp(GREY, offline ? 0.8 : 0);
  }

  /**
   * @param {{name: string, mode: string, controller: string, offline: boolean, age: number | null,
   *   selected: boolean, warning: boolean, stale?: string | null}} state `stale`: why what is shown is old
   *   (the connection, the robot's pose), drawn grey like an offline robot
   */
  setStatus(state) {
    const old = state.offline || Boolean(state.stale);
    this.setOffline(old);
    this.stale = state.stale ?? null;
    const second = state.stale
      ? `${state.stale} · was ${state.mode}`
      : state.offline
        ? `offline${state.age !== null ? ` · ${formatAge(state.age)}` : ''}`
        : `${state.mode}${state.controller ? ` · ${state.controller}` : ''}`;
    this.label.set([state.name, second], { accent: `#${this.colour.getHexString()}`, dim: old });
    this.ring.visible = state.selected;
    this.warning.sprite.visible = state.warning;
  }

  /** A scan message in the robot frame (see scan.js). @param {any} message */
  setScan(message) {
    const n = scanToPoints(message, this.scanXY);
    for (let i = 0; i < n; i++) {
      // Robot frame (x forward, y left) to the robot group's glTF frame, 15 cm above the floor.
      this.scanPositions[3 * i] = this.scanXY[2 * i];
      this.scanPositions[3 * i + 1] = 0.15;
      this.scanPositions[3 * i + 2] = -this.scanXY[2 * i + 1];
    }
    const geometry = this.scan.geometry;
    geometry.setDrawRange(0, n);
    const attribute = /** @type {THREE.BufferAttribute} */ (geometry.getAttribute('position'));
    attribute.clearUpdateRanges();
    attribute.addUpdateRange(0, n * 3);
    attribute.needsUpdate = true;
  }

  dispose() {
    this.disposed = true;
    this.loadGeneration++;
    this.group.removeFromParent();
    this.label.dispose();
    this.warning.dispose();
    for (const g of this.geometries) g.dispose();
    for (const m of this.materials) m.dispose();
  }
}

/** @param {number} seconds */
export function formatAge(seconds) {
  if (seconds < 60) return `${Math.round(seconds)} s ago`;
  if (seconds < 3600) return `${Math.round(seconds / 60)} min ago`;
  return `${Math.round(seconds / 3600)} h ago`;
}
