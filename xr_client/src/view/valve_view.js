// @ts-check
/**
 * The facility's valve wheel in the twin (`valve`, sim backend): a handwheel on a short stem out of its valve body, on
 * a riser from the floor, at the place the relay reports, turning by the angle it reports (valve.js
 * `valvePlacement`). The handle, a knob standing out of the rim toward whoever turns it, shows the turn at a glance;
 * the wheel is red while open, green once shut, and lit while a gripper holds it. Nothing is drawn until the relay
 * reports a valve. dispose() releases what it allocated.
 */
import * as THREE from 'three';
import { valvePlacement } from '../valve.js';

const OPEN = new THREE.Color('#c62828');
const SHUT = new THREE.Color('#2e9d57');
const HELD = new THREE.Color('#553300');
const UNLIT = new THREE.Color(0);
const SPOKES = 3;

export class ValveView {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'valve';
    this.group.visible = false;
    /** The wheel, its spokes and its handle: turned about local +x (the axis). */
    this.spin = new THREE.Group();
    this.group.add(this.spin);
    this.wheelMaterial = new THREE.MeshStandardMaterial({ color: OPEN, roughness: 0.5, metalness: 0.2 });
    // Galvanised, but not metallic: without an environment map to reflect, metal draws black.
    this.metal = new THREE.MeshStandardMaterial({ color: '#a4aab2', roughness: 0.45, metalness: 0.2 });
    /** @type {THREE.BufferGeometry[]} */
    this.geometries = [];
    /** The rim's radius the wheel was built for (m); rebuilt when the relay reports another. */
    this.radius = 0;
  }

  /**
   * Draw the newest report (null: no valve). @param {import('../protocol.js').ValveMessage | null} valve
   * @param {import('../frames.js').MapToScene} t
   */
  update(valve, t) {
    this.group.visible = valve !== null;
    if (valve === null) return;
    if (valve.radius !== this.radius) this.#build(valve.radius, valve.z);
    const { position, heading, angle } = valvePlacement(t, valve);
    this.group.position.fromArray(position);
    this.group.rotation.set(0, heading, 0);
    this.spin.rotation.set(angle, 0, 0);
    this.wheelMaterial.color.copy(valve.shut ? SHUT : OPEN);
    this.wheelMaterial.emissive.copy(valve.held ? HELD : UNLIT);
  }

  /** The wheel of rim radius `r` (m) on its stem, body and riser; `z`: the centre's height over the floor (m). */
  #build(/** @type {number} */ r, /** @type {number} */ z) {
    this.#clear();
    this.radius = r;
    const tube = Math.max(0.004, r * 0.14);
    const rim = this.#geometry(new THREE.TorusGeometry(r, tube, 12, 40));
    const wheel = new THREE.Mesh(rim, this.wheelMaterial);
    wheel.rotation.y = Math.PI / 2; // the torus lies in its x-y plane: turned into the y-z plane, about the axis x
    const spoke = this.#geometry(new THREE.CylinderGeometry(tube * 0.6, tube * 0.6, 2 * r, 8));
    /** @type {THREE.Object3D[]} */
    const parts = [wheel];
    for (let i = 0; i < SPOKES; i++) {
      const bar = new THREE.Mesh(spoke, this.wheelMaterial);
      bar.rotation.x = (i * Math.PI) / SPOKES; // spokes in the wheel's plane, through the hub
      parts.push(bar);
    }
    const hub = new THREE.Mesh(
      this.#geometry(new THREE.CylinderGeometry(tube * 1.6, tube * 1.6, tube * 3, 16)),
      this.metal,
    );
    hub.rotation.z = Math.PI / 2;
    // The handle: a knob out of the rim's top toward the front, where a hand (or a gripper) takes the wheel.
    const knob = new THREE.Mesh(
      this.#geometry(new THREE.CylinderGeometry(tube, tube * 1.2, r * 0.7, 12)),
      this.wheelMaterial,
    );
    knob.rotation.z = -Math.PI / 2;
    knob.position.set(r * 0.35, r, 0);
    parts.push(hub, knob);
    this.spin.add(...parts);
    // Behind the wheel (local -x): the stem into the valve's body on its riser, from the floor up past it.
    const stem = new THREE.Mesh(this.#geometry(new THREE.CylinderGeometry(tube, tube, r * 1.6, 10)), this.metal);
    stem.rotation.z = Math.PI / 2;
    stem.position.x = -r * 0.8;
    const body = new THREE.Mesh(this.#geometry(new THREE.SphereGeometry(r * 0.9, 16, 12)), this.metal);
    body.position.x = -r * 1.9;
    const riserLength = z + 3 * r;
    const riser = new THREE.Mesh(
      this.#geometry(new THREE.CylinderGeometry(r * 0.55, r * 0.55, riserLength, 16)),
      this.metal,
    );
    riser.position.set(-r * 1.9, riserLength / 2 - z, 0);
    this.group.add(stem, body, riser);
  }

  /** @template {THREE.BufferGeometry} G @param {G} geometry @returns {G} */
  #geometry(geometry) {
    this.geometries.push(geometry);
    return geometry;
  }

  #clear() {
    this.spin.clear();
    for (const child of [...this.group.children]) if (child !== this.spin) child.removeFromParent();
    for (const geometry of this.geometries) geometry.dispose();
    this.geometries = [];
  }

  dispose() {
    this.#clear();
    this.group.removeFromParent();
    this.wheelMaterial.dispose();
    this.metal.dispose();
  }
}
