// @ts-check
/**
 * One robot in the twin: what is its own (its loaded glTF model, tinted with its colour through the material named
 * `body`; its laser scan points in the robot frame; the selection ring; the red warning icon) and its place in what
 * the fleet shares (view/fleet_instances.js: the built-in shape and the footprint with its heading arrow, one
 * InstancedMesh per part for every robot; view/label_atlas.js: every label in one texture and one draw call).
 * The full model is drawn only for the nearest few robots (level_of_detail.js), the shared shape for the others.
 * Offline, the robot is greyed and its label shows the age of its data. The view only reads the fleet model.
 *
 * Nothing is allocated per pose: place() writes positions in place; a label is redrawn in its atlas cell only
 * when its text changes. Measured with 100 robots (bench client_frame, SwiftShader, 2 cores, VR): 1576 draw calls a
 * frame before (a dozen objects and ~8 draw calls per robot, 100 label textures), 0.07 frames/s; 118 after (with
 * the twin merged), 5.5 frames/s, app JS p50 4.6 ms (docs/client.md).
 */
import * as THREE from 'three';
import { adoptMaterials } from './model_materials.js';
import { WarningSprite } from './label_sprite.js';
import { LABEL_ASPECT } from './label_atlas.js';
import { MAX_SCAN_POINTS, scanToPoints } from '../scan.js';
import { HEADSET_PX_PER_RAD, LABEL_ANGLE, LABEL_MAX, LABEL_MIN, labelAngle, labelHeight } from '../label_rule.js';

export { LABEL_ANGLE, LABEL_MAX, LABEL_MIN };
const GREY = new THREE.Color('#777777');
/** Where labels hang from: the top of a TurtleBot-sized robot (m). */
export const LABEL_ANCHOR = 0.45;

export class RobotView {
  /**
   * @param {import('../fleet_model.js').RobotDescription} description
   * @param {import('./gltf_loading.js').ModelLoader} loader
   * @param {number} index the robot's instance in the shared parts and its cell in the label atlas
   * @param {import('./fleet_instances.js').FleetInstances} shared
   * @param {import('./label_atlas.js').LabelAtlas} atlas
   */
  constructor(description, loader, index, shared, atlas) {
    this.name = description.name;
    this.index = index;
    this.shared = shared;
    this.atlas = atlas;
    this.colour = new THREE.Color(description.colour);
    this.group = new THREE.Group();
    this.group.name = `robot:${description.name}`;
    this.group.userData.robot = description.name;
    this.group.visible = false; // until its first pose
    /** Holds the invisible proxy that picking meets, and the full model once loaded while it is drawn (detailed). */
    this.body = new THREE.Group();
    this.group.add(this.body);
    this.proxy = new THREE.Mesh(shared.proxyGeometry, shared.proxyMaterial);
    this.proxy.userData.robot = this.name;
    this.body.add(this.proxy);
    /** The loaded glTF (a clone), in `body` only while it is drawn: 96 undrawn models' 12 nodes each were matrix
     * updates every frame for nothing. @type {THREE.Object3D | null} */
    this.model = null;
    /** Whether the full model is loaded, and whether it is drawn this frame (level_of_detail.js). */
    this.hasModel = false;
    this.detailed = false;
    /** @type {THREE.Material[]} materials owned by this view (the model's copies) */
    this.materials = [];
    /** @type {THREE.BufferGeometry[]} */
    this.geometries = [];
    shared.setRobot(index, description.cameras.length > 0, this.colour);
    this.loadGeneration = 0;
    if (description.model) this.#loadModel(description.model, loader);

    // The label is drawn by the atlas; this invisible sprite of the same size is what the desktop's mouse picks,
    // and what the state snapshot measures. Anchored at the robot's top and drawn above that point on screen.
    const sprite = new THREE.Sprite(shared.labelProxyMaterial);
    sprite.position.set(0, LABEL_ANCHOR, 0);
    sprite.center.set(0.5, -0.35);
    sprite.userData.robot = description.name;
    this.group.add(sprite);
    /** @type {{sprite: THREE.Sprite, key: string}} */
    this.label = { sprite, key: '' };
    /** Its lines (name, state, and a goal's progress when it has one): a taller label keeps each line legible. */
    this.labelLines = 2;
    /** The label is kept whatever the distance (the selected robot's, a warning's): label_rule.js. */
    this.keepLabel = false;
    this.warning = new WarningSprite(shared.warningMaterial);
    // Above the label: the icon is 0.05 of the view high (sizeAttenuation off), the label LABEL_ANGLE, ~1.4 times
    // less; a centre 1.05 icons below it clears the label's top (0.35 + 1 label heights up).
    this.warning.sprite.position.set(0, LABEL_ANCHOR, 0);
    this.warning.sprite.center.set(0.5, -1.05);
    this.warning.sprite.visible = false;
    this.group.add(this.warning.sprite);

    /** Turned with the robot: the footprint's heading (drawn by the shared instances; the snapshot reads it). */
    this.heading = new THREE.Group();
    this.heading.name = `footprint:${this.name}`;
    this.group.add(this.heading);

    this.ring = new THREE.Mesh(shared.ringGeometry, shared.ringMaterial);
    this.ring.position.y = 0.01;
    this.ring.visible = false;
    this.ring.raycast = () => {};
    this.group.add(this.ring);

    /**
     * The latest laser scan, in the robot frame (x, y pairs); the fleet's scans are drawn together (fleet_scans.js).
     */
    this.scanXY = new Float32Array(MAX_SCAN_POINTS * 2);
    this.scanCount = 0;
    this.scanVisible = true;
    /** A scan came since the last pack; where the robot was at that pack. */
    this.scanNew = false;
    this.packed = { x: NaN, z: NaN, yaw: NaN };
    this.offline = false;
    this.yaw = 0;
    /** Why what this view shows is old (the link, the pose), or null while it is live. @type {string | null} */
    this.stale = null;
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
      this.model = model;
      this.hasModel = true;
      this.#applyTint();
      this.setDetailed(this.detailed, true);
    } catch (error) {
      console.warn(`robot ${this.name}: model ${url} could not be loaded; keeping the built-in shape`, error);
    }
  }

  /**
   * The label keeps about the same size on screen (label_rule.js), each of its lines at least 12 px; the atlas
   * draws it, the proxy sprite follows.
   * @param {number} distance from the viewer, metres @param {number} [pxPerRad] the screen's pixels per radian
   */
  scaleLabel(distance, pxPerRad = HEADSET_PX_PER_RAD) {
    const h = labelHeight(distance, labelAngle(this.labelLines, pxPerRad));
    this.label.sprite.scale.set(h * LABEL_ASPECT, h, 1);
    return h;
  }

  /**
   * Whether the full model is drawn (else the shared shape is). Picking meets the proxy either way: a ray from a
   * hand or the eyes 8 m away finds a 44 cm cylinder, where a 14 cm TurtleBot's thin parts slip between its
   * pixels (tests/e2e/test_gaze_pinch.py aims at the model's middle; the proxy makes the robot's size the target).
   * @param {boolean} detailed @param {boolean} [force]
   */
  setDetailed(detailed, force = false) {
    if (detailed === this.detailed && !force) return;
    this.detailed = detailed;
    const model = this.model;
    if (!model) return;
    if (detailed && model.parent !== this.body) this.body.add(model);
    else if (!detailed && model.parent === this.body) this.body.remove(model);
  }

  /** Show or hide the laser scan (the operator's Scans switch). @param {boolean} on */
  showScan(on) {
    this.scanVisible = on;
  }

  /** Whether the scan must be packed again: a new one came, or the robot moved since (1 cm, 0.3 degree). */
  scanMoved() {
    const p = this.packed;
    return (
      this.scanNew ||
      !(
        Math.abs(p.x - this.group.position.x) < 0.01 &&
        Math.abs(p.z - this.group.position.z) < 0.01 &&
        Math.abs(p.yaw - this.yaw) < 0.005
      )
    );
  }

  /** The scan was packed with the robot here. @param {number} x @param {number} z @param {number} yaw */
  packedAt(x, z, yaw) {
    this.packed.x = x;
    this.packed.z = z;
    this.packed.yaw = yaw;
    this.scanNew = false;
  }

  /**
   * Place the robot (scene coordinates, yaw about +y).
   * @param {number} x @param {number} y @param {number} z @param {number} yaw
   */
  place(x, y, z, yaw) {
    this.group.visible = true;
    this.group.position.set(x, y, z);
    this.yaw = yaw;
    this.body.rotation.y = yaw;
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
      if (!mesh.isMesh || mesh === this.proxy) return; // the proxy's material is shared, and never drawn
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
    this.shared.tint(this.index, this.colour, offline);
  }

  /**
   * @param {{name: string, mode: string, controller: string, offline: boolean, age: number | null,
   *   selected: boolean, warning: boolean, stale?: string | null, nav?: string}} state `stale`: why what is shown
   *   is old (the connection, the robot's pose), drawn grey like an offline robot; `nav`: Nav2's feedback or the
   *   goal's outcome (nav_line.js), a third line when not empty
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
    const lines = state.nav ? [state.name, second, state.nav] : [state.name, second];
    this.labelLines = lines.length;
    const style = { accent: `#${this.colour.getHexString()}`, dim: old };
    const key = JSON.stringify([lines, style]);
    if (key !== this.label.key) {
      this.label.key = key;
      this.atlas.draw(this.index, lines, style);
    }
    this.ring.visible = state.selected;
    this.warning.sprite.visible = state.warning;
    this.keepLabel = state.selected || state.warning;
  }

  /** A scan message in the robot frame (see scan.js): kept until the fleet's scans are packed. @param {any} message */
  setScan(message) {
    this.scanCount = scanToPoints(message, this.scanXY);
    this.scanNew = true;
  }

  dispose() {
    this.disposed = true;
    this.loadGeneration++;
    this.group.removeFromParent();
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
