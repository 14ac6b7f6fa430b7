// @ts-check
/**
 * Robots' arms in the twin, drawn from their joint states (`<robot>/joints`): a rod per link between the points of
 * the arm's skeleton (the relay works them out from the URDF), a ball at each joint, and a gripper at the tip whose
 * jaws open with the gripper joint. Each arm hangs in its robot's body (so it follows the robot's pose and heading)
 * and moves smoothly between joint states (arm_jog.js `approach`). The robots' glTF models are not built from their
 * URDFs here, so there are no link nodes to pose: this is the arm's simple drawing, in the robot's colour.
 *
 * Geometry and materials are shared by every arm; nothing is allocated per frame. dispose() releases them.
 */
import * as THREE from 'three';
import { approach } from '../arm_jog.js';

const ROD_RADIUS = 0.012; // m: OpenManipulator-X's links are about 2.5 cm thick
const UP = new THREE.Vector3(0, 1, 0);
const from = new THREE.Vector3();
const to = new THREE.Vector3();
const along = new THREE.Vector3();
const side = new THREE.Vector3();

/** The arm's base link (REP 103: x forward, y left, z up) to the glTF frame of the robot's body (y up, z back). */
function toBody(/** @type {number[]} */ p, /** @type {THREE.Vector3} */ out) {
  return out.set(p[0], p[2], -p[1]);
}

class ArmView {
  /** @param {THREE.BufferGeometry} rod @param {THREE.BufferGeometry} ball @param {THREE.Material} material */
  constructor(rod, ball, material) {
    this.group = new THREE.Group();
    this.group.name = 'arm';
    this.rod = rod;
    this.ball = ball;
    this.material = material;
    /** @type {THREE.Mesh[]} */
    this.rods = [];
    /** @type {THREE.Mesh[]} */
    this.balls = [];
    this.jaws = [new THREE.Mesh(rod, material), new THREE.Mesh(rod, material)];
    this.group.add(...this.jaws);
    /** The drawn skeleton, approaching the newest joint state's. @type {number[][]} */
    this.points = [];
  }

  /** @param {import('../protocol.js').JointsMessage} joints @param {number} dt s */
  update(joints, dt) {
    approach(this.points, joints.points, dt);
    const n = this.points.length;
    while (this.rods.length < n - 1) this.#add(this.rods, this.rod);
    while (this.balls.length < n) this.#add(this.balls, this.ball);
    for (let i = 0; i < n; i++) toBody(this.points[i], this.balls[i].position);
    for (let i = 0; i < n - 1; i++) this.#rodBetween(this.rods[i], this.points[i], this.points[i + 1]);
    if (n >= 2) this.#gripper(joints, this.points[n - 2], this.points[n - 1]);
  }

  /** @param {THREE.Mesh[]} list @param {THREE.BufferGeometry} geometry */
  #add(list, geometry) {
    const mesh = new THREE.Mesh(geometry, this.material);
    list.push(mesh);
    this.group.add(mesh);
  }

  /** @param {THREE.Object3D} rod @param {number[]} a @param {number[]} b */
  #rodBetween(rod, a, b) {
    toBody(a, from);
    toBody(b, to);
    along.subVectors(to, from);
    const length = along.length();
    rod.visible = length > 1e-4;
    if (!rod.visible) return;
    rod.position.addVectors(from, to).multiplyScalar(0.5);
    rod.quaternion.setFromUnitVectors(UP, along.divideScalar(length));
    rod.scale.set(1, length, 1);
  }

  /**
   * Two jaws beside the tip, across the last link, apart by the gripper joint's opening (the joint after the chain's).
   * @param {import('../protocol.js').JointsMessage} joints @param {number[]} before @param {number[]} tip
   */
  #gripper(joints, before, tip) {
    // The skeleton is the base, each joint of the chain and the tip: the gripper joint comes right after the chain's.
    const opening = joints.positions[joints.points.length - 2] ?? 0;
    toBody(tip, to);
    toBody(before, from);
    along.subVectors(to, from).normalize();
    // Sideways: across the last link, level (the arm's y axis turned with the link about the vertical).
    side.set(-along.z, 0, along.x);
    if (side.lengthSq() < 1e-8) side.set(0, 0, 1);
    side.normalize().multiplyScalar(0.02 + Math.max(-0.01, opening));
    this.jaws[0].position.copy(to).add(side);
    this.jaws[1].position.copy(to).sub(side);
    for (const jaw of this.jaws) {
      jaw.quaternion.setFromUnitVectors(UP, along);
      jaw.scale.set(0.6, 0.04, 0.6);
    }
  }
}

export class ArmViews {
  constructor() {
    this.rod = new THREE.CylinderGeometry(ROD_RADIUS, ROD_RADIUS, 1, 10);
    this.ball = new THREE.SphereGeometry(ROD_RADIUS * 1.4, 12, 8);
    /** One material per robot colour. @type {Map<string, THREE.MeshStandardMaterial>} */
    this.materials = new Map();
    /** @type {Map<string, ArmView>} */
    this.views = new Map();
  }

  /**
   * Pose every arm from its newest joint state, in its robot's view.
   * @param {Map<string, import('../protocol.js').JointsMessage>} arms
   * @param {Map<string, import('./robot_view.js').RobotView>} robotViews @param {number} dt s
   */
  update(arms, robotViews, dt) {
    for (const [robot, joints] of arms) {
      const robotView = robotViews.get(robot);
      if (!robotView) continue;
      let view = this.views.get(robot);
      if (!view || view.group.parent !== robotView.body) {
        view?.group.removeFromParent();
        view = new ArmView(this.rod, this.ball, this.#material(robotView.colour));
        this.views.set(robot, view);
        robotView.body.add(view.group);
      }
      view.update(joints, dt);
    }
  }

  /** @param {THREE.Color} colour */
  #material(colour) {
    const key = colour.getHexString();
    let material = this.materials.get(key);
    if (!material) {
      material = new THREE.MeshStandardMaterial({ color: colour.clone().lerp(new THREE.Color('#bbbbbb'), 0.5) });
      this.materials.set(key, material);
    }
    return material;
  }

  dispose() {
    for (const view of this.views.values()) view.group.removeFromParent();
    this.views.clear();
    this.rod.dispose();
    this.ball.dispose();
    for (const material of this.materials.values()) material.dispose();
    this.materials.clear();
  }
}
