// @ts-check
/**
 * Inspection in the twin: each target as a ring on the floor with its name, each finding as a pin coloured by how
 * much its target changed since the last round, else by its status (change_colour.js), at its map position (only
 * what changed while the model's "since last round" is on), a picked target amber with its place in the order.
 * Redrawn only when the model, the review or the twin changes (never per frame: a frame takes 100-300 ms under
 * SwiftShader); geometries and materials are shared by all pins.
 */
import * as THREE from 'three';
import { mapToScene } from '../frames.js';
import { changeColour } from '../change_colour.js';
import { LabelSprite } from './label_sprite.js';

export class InspectionView {
  group = new THREE.Group();
  /** @type {LabelSprite[]} */
  #labels = [];
  #ring = new THREE.RingGeometry(0.28, 0.36, 32).rotateX(-Math.PI / 2);
  #ringMaterial = new THREE.MeshBasicMaterial({
    color: 0x4fc3f7,
    transparent: true,
    opacity: 0.85,
    side: THREE.DoubleSide,
  });
  #pickedMaterial = new THREE.MeshBasicMaterial({
    color: 0xffb020,
    transparent: true,
    opacity: 0.95,
    side: THREE.DoubleSide,
  });
  /** A target is picked by a disc a little wider than its ring (a ray grazing the floor misses a thin ring). */
  #disc = new THREE.CircleGeometry(0.5, 24).rotateX(-Math.PI / 2);
  #hidden = new THREE.MeshBasicMaterial({ visible: false });
  /** @type {THREE.Object3D[]} rings' discs and pins: what a VR ray may select */
  #pickables = [];
  #stick = new THREE.CylinderGeometry(0.015, 0.015, 1.2, 8).translate(0, 0.6, 0);
  #head = new THREE.SphereGeometry(0.09, 16, 12).translate(0, 1.25, 0);
  /** One material a colour, made when first needed (a few: the statuses and the change scores seen). */
  /** @type {Map<string, THREE.MeshBasicMaterial>} */
  #pinMaterials = new Map();
  /** Each pin's colour and label, by finding id (the page's state snapshot shows them). */
  /** @type {Record<string, {colour: string, label: string}>} */
  pins = {};
  #key = '';

  /** @param {THREE.Group} world */
  constructor(world) {
    this.group.name = 'inspection';
    world.add(this.group);
  }

  /**
   * Rebuild the markers when the model or the review (targets picked in order) changed.
   * @param {import('../inspection_model.js').InspectionModel} model
   * @param {import('../inspection_review.js').InspectionReview} review
   * @param {import('../frames.js').MapToScene} transform the twin's map-to-scene transform
   */
  update(model, review, transform) {
    const key = `${model.version}|${review.version}|${transform.x},${transform.y},${transform.z},${transform.yaw}`;
    if (key === this.#key) return;
    this.#key = key;
    this.#clear();
    for (const target of model.targets.values()) {
      const order = review.picked.indexOf(target.id);
      const ring = new THREE.Mesh(this.#ring, order >= 0 ? this.#pickedMaterial : this.#ringMaterial);
      ring.position.set(...mapToScene(transform, target.x, target.y, 0.02));
      ring.name = `target:${target.id}`;
      const disc = new THREE.Mesh(this.#disc, this.#hidden);
      ring.add(disc);
      this.#pickables.push(disc);
      const label = new LabelSprite({ worldHeight: 0.18 });
      label.set([order >= 0 ? `${order + 1} · ${target.name}` : target.name, target.kind], {
        accent: order >= 0 ? '#ffb020' : '#4fc3f7',
      });
      label.sprite.position.set(...mapToScene(transform, target.x, target.y, 0.45));
      this.#labels.push(label);
      this.group.add(ring, label.sprite);
    }
    // Several findings at one target stand side by side, newest at the target itself.
    /** @type {Map<string, number>} */
    const seen = new Map();
    this.pins = {};
    for (const finding of model.visible()) {
      const key = `${finding.x.toFixed(2)},${finding.y.toFixed(2)}`;
      const n = seen.get(key) ?? 0;
      seen.set(key, n + 1);
      const pin = new THREE.Group();
      pin.name = `finding:${finding.id}`;
      const look = changeColour(finding);
      this.pins[finding.id] = look;
      const material = this.#material(look.colour);
      pin.add(new THREE.Mesh(this.#stick, material), new THREE.Mesh(this.#head, material));
      for (const part of pin.children) part.renderOrder = 15;
      pin.position.set(...mapToScene(transform, finding.x + 0.25 * n, finding.y, 0));
      this.group.add(pin);
      this.#pickables.push(pin);
    }
  }

  /** @param {string} colour */
  #material(colour) {
    let material = this.#pinMaterials.get(colour);
    if (!material) {
      // Pins are drawn over the twin (no depth test), like RViz markers: findings in a room are seen from the corridor.
      material = new THREE.MeshBasicMaterial({ color: colour, depthTest: false, transparent: true, opacity: 0.92 });
      this.#pinMaterials.set(colour, material);
    }
    return material;
  }

  /** What a VR ray may select: each target's disc (named by its ring) and each finding's pin. */
  pickables() {
    return this.#pickables;
  }

  #clear() {
    for (const label of this.#labels) label.dispose();
    this.#labels = [];
    this.#pickables = [];
    this.group.clear();
  }

  dispose() {
    this.#clear();
    this.group.removeFromParent();
    this.#ring.dispose();
    this.#stick.dispose();
    this.#head.dispose();
    this.#ringMaterial.dispose();
    this.#pickedMaterial.dispose();
    this.#disc.dispose();
    this.#hidden.dispose();
    for (const material of this.#pinMaterials.values()) material.dispose();
  }
}
