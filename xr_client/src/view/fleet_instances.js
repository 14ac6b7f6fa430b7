// @ts-check
/**
 * What every robot is drawn with, shared: the built-in shape (a TurtleBot-sized base, its dark trim, a camera dome
 * on robots that have a camera) and the footprint on the floor (a disc and its edge with the heading arrow), each an
 * InstancedMesh with one instance per robot in the robot's colour. One draw call per part for the whole fleet,
 * however large: before, each robot had its own geometries and materials (a dozen objects, ~8 draw calls, per robot;
 * 1576 draw calls a frame in VR with 100 robots, ~30 ms of three.js's JavaScript a frame on a 2-core machine).
 * Robots shown with their full glTF model (the nearest few, level_of_detail.js) hide their instance of the shape.
 * Also here: the materials and geometries every RobotView shares (selection ring, warning icon, pick proxies).
 * Instance matrices are written in place each frame; colours only when a robot's tint changes.
 */
import * as THREE from 'three';
import { mergeGeometries } from 'three/addons/utils/BufferGeometryUtils.js';
import { WarningSprite } from './label_sprite.js';

/** The footprint's radius (m): a TurtleBot-sized base, the built-in shape's 0.2 m and a margin. */
export const FOOTPRINT = 0.26;
const GREY = new THREE.Color('#777777');
/** Nothing to draw: an instance scaled to zero. */
const HIDDEN = new THREE.Matrix4().makeScale(0, 0, 0);

export class FleetInstances {
  /** @param {number} count robots */
  constructor(count) {
    this.count = count;
    const n = Math.max(1, count);
    this.group = new THREE.Group();
    this.group.name = 'fleet-instances';
    // A TurtleBot-sized base: 0.4 m round, forward along +x like the robot frame.
    const body = new THREE.CylinderGeometry(0.2, 0.2, 0.22, 32).translate(0, 0.13, 0);
    const trim = new THREE.BoxGeometry(0.12, 0.06, 0.24).translate(0.14, 0.27, 0);
    const dome = new THREE.SphereGeometry(0.05, 16, 12).translate(0.16, 0.33, 0);
    const disc = new THREE.CircleGeometry(FOOTPRINT, 40).rotateX(-Math.PI / 2).translate(0, 0.012, 0);
    // The arrow points along +x (the robot's forward) from the footprint's edge: 0.45 m long, so that the heading
    // reads from 20 m away, where the robot itself is a dozen pixels.
    const arrow = new THREE.Shape();
    arrow.moveTo(FOOTPRINT + 0.45, 0);
    arrow.lineTo(FOOTPRINT - 0.02, 0.16);
    arrow.lineTo(FOOTPRINT + 0.08, 0);
    arrow.lineTo(FOOTPRINT - 0.02, -0.16);
    arrow.closePath();
    const edge = new THREE.RingGeometry(FOOTPRINT - 0.025, FOOTPRINT, 40).rotateX(-Math.PI / 2).translate(0, 0.014, 0);
    const arrowGeometry = new THREE.ShapeGeometry(arrow).rotateX(-Math.PI / 2).translate(0, 0.016, 0);
    const outline = /** @type {THREE.BufferGeometry} */ (
      mergeGeometries([edge.deleteAttribute('normal'), arrowGeometry.deleteAttribute('normal')])
    );
    edge.dispose();
    arrowGeometry.dispose();
    // White materials: the instance colour is the robot's (three multiplies the two).
    const bodyMaterial = new THREE.MeshStandardMaterial({ name: 'body', color: '#ffffff', roughness: 0.6 });
    const trimMaterial = new THREE.MeshStandardMaterial({ color: '#222831', roughness: 0.8 });
    const domeMaterial = new THREE.MeshStandardMaterial({ color: '#0b0d12', roughness: 0.2, metalness: 0.5 });
    const fill = new THREE.MeshBasicMaterial({ color: '#ffffff', transparent: true, opacity: 0.28, depthWrite: false });
    const solid = new THREE.MeshBasicMaterial({
      color: '#ffffff',
      transparent: true,
      opacity: 0.95,
      depthWrite: false,
    });
    /** @param {THREE.BufferGeometry} geometry @param {THREE.Material} material @param {string} name */
    const instanced = (geometry, material, name) => {
      const mesh = new THREE.InstancedMesh(geometry, material, n);
      mesh.name = name;
      mesh.count = count;
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      mesh.frustumCulled = false; // instances move: a bounding sphere computed once would cull them wrongly
      mesh.raycast = () => {}; // robots are picked through their own proxies (robot_view.js)
      for (let i = 0; i < n; i++) mesh.setMatrixAt(i, HIDDEN);
      this.group.add(mesh);
      return mesh;
    };
    this.bodies = instanced(body, bodyMaterial, 'robot-bodies');
    this.trims = instanced(trim, trimMaterial, 'robot-trims');
    this.domes = instanced(dome, domeMaterial, 'robot-cameras');
    this.discs = instanced(disc, fill, 'footprint-discs');
    this.outlines = instanced(outline, solid, 'footprint-outlines');
    for (const mesh of [this.discs, this.outlines]) mesh.renderOrder = 2; // above the floor, below the selection ring
    /** Whether each robot has a camera (its dome is drawn). */
    this.cameras = new Uint8Array(n);
    this.colour = new THREE.Color();
    this.matrix = new THREE.Matrix4();
    this.rotation = new THREE.Matrix4();

    // -- shared by every RobotView ---------------------------------------------------------------
    this.ringGeometry = new THREE.RingGeometry(0.32, 0.38, 48).rotateX(-Math.PI / 2);
    this.ringMaterial = new THREE.MeshBasicMaterial({ color: '#ffffff', transparent: true, opacity: 0.85 });
    this.warningMaterial = WarningSprite.material();
    /** What a ray meets when it picks a robot drawn by the instances (never drawn). */
    this.proxyGeometry = new THREE.CylinderGeometry(0.22, 0.22, 0.4, 8).translate(0, 0.2, 0);
    this.proxyMaterial = new THREE.MeshBasicMaterial({ visible: false });
    /** The labels' pick proxies (never drawn): the desktop's mouse picks a robot by its label too. */
    this.labelProxyMaterial = new THREE.SpriteMaterial({ visible: false });
  }

  /** @param {number} i @param {boolean} hasCamera @param {THREE.Color} colour */
  setRobot(i, hasCamera, colour) {
    if (i < 0 || i >= this.count) return;
    this.cameras[i] = hasCamera ? 1 : 0;
    this.tint(i, colour, false);
  }

  /**
   * A robot's colour, greyed while it is offline or its data is old. @param {number} i @param {THREE.Color} colour
   * @param {boolean} grey
   */
  tint(i, colour, grey) {
    if (i < 0 || i >= this.count) return;
    this.colour.copy(colour);
    if (grey) this.colour.lerp(GREY, 0.8);
    for (const mesh of [this.bodies, this.discs, this.outlines]) {
      mesh.setColorAt(i, this.colour);
      /** @type {THREE.InstancedBufferAttribute} */ (mesh.instanceColor).needsUpdate = true;
    }
  }

  /**
   * Robot i this frame: where (scene), its yaw, whether its built-in shape is drawn (not when its full model is).
   * @param {number} i @param {THREE.Vector3 | null} position null: not drawn (no pose yet)
   * @param {number} yaw @param {boolean} shape
   */
  place(i, position, yaw, shape) {
    if (i < 0 || i >= this.count) return;
    if (!position) {
      for (const mesh of [this.bodies, this.trims, this.domes, this.discs, this.outlines]) mesh.setMatrixAt(i, HIDDEN);
      return;
    }
    this.matrix.makeRotationY(yaw).setPosition(position);
    this.discs.setMatrixAt(i, this.matrix);
    this.outlines.setMatrixAt(i, this.matrix);
    this.bodies.setMatrixAt(i, shape ? this.matrix : HIDDEN);
    this.trims.setMatrixAt(i, shape ? this.matrix : HIDDEN);
    this.domes.setMatrixAt(i, shape && this.cameras[i] ? this.matrix : HIDDEN);
  }

  /** After place() for this frame's robots: upload the matrices. */
  placed() {
    for (const mesh of [this.bodies, this.trims, this.domes, this.discs, this.outlines])
      mesh.instanceMatrix.needsUpdate = true;
  }

  dispose() {
    this.group.removeFromParent();
    for (const mesh of [this.bodies, this.trims, this.domes, this.discs, this.outlines]) {
      mesh.geometry.dispose();
      /** @type {THREE.Material} */ (mesh.material).dispose();
      mesh.dispose();
    }
    this.ringGeometry.dispose();
    this.ringMaterial.dispose();
    this.warningMaterial.map?.dispose();
    this.warningMaterial.dispose();
    this.proxyGeometry.dispose();
    this.proxyMaterial.dispose();
    this.labelProxyMaterial.dispose();
  }
}
