// @ts-check
/**
 * Every robot's laser scan in one THREE.Points (one draw call for the fleet, not one per robot: with 100 robots the
 * scans were 200 of a VR frame's 422 draw calls). Each robot keeps its latest scan in its own frame (robot_view.js);
 * here they are placed with the robots' drawn poses into one packed buffer, in the robots' colours, at most
 * REPACK_HZ times a second and only when a scan came or a robot moved: a scan is a picture of the walls taken at
 * one moment, redrawn 10 times a second it stays on them within a few centimetres of a moving robot (5 cm at
 * 0.5 m/s). Nothing is allocated per pack; the buffer grows (doubling) when a fleet's scans outgrow it.
 */
import * as THREE from 'three';

/** Repacks a second, at most. */
const REPACK_HZ = 10;
/** Height of the scan plane above the floor (m). */
const HEIGHT = 0.15;

export class FleetScans {
  /** @param {number} pointsPerRobot the buffer's first size, per robot (grows when needed) */
  constructor(pointsPerRobot = 400) {
    this.capacity = 0;
    this.geometry = new THREE.BufferGeometry();
    // A few pixels whatever the distance (as RViz draws points): 6 cm dots were invisible from across the site.
    this.material = new THREE.PointsMaterial({ size: 3.5, sizeAttenuation: false, vertexColors: true });
    this.points = new THREE.Points(this.geometry, this.material);
    this.points.name = 'scans';
    this.points.frustumCulled = false;
    this.points.raycast = () => {};
    this.positions = new Float32Array(0);
    this.colours = new Float32Array(0);
    this.pointsPerRobot = pointsPerRobot;
    this.lastPack = -Infinity;
    /** A scan came (or the switch changed) since the last pack. */
    this.changed = false;
    /** Points drawn now. */
    this.drawn = 0;
  }

  /** @param {number} points */
  #grow(points) {
    if (points <= this.capacity) return;
    this.capacity = Math.max(points, 2 * this.capacity);
    this.positions = new Float32Array(this.capacity * 3);
    this.colours = new Float32Array(this.capacity * 3);
    this.geometry.dispose(); // the old buffers on the GPU; the geometry is set up again below
    this.geometry.setAttribute(
      'position',
      new THREE.BufferAttribute(this.positions, 3).setUsage(THREE.DynamicDrawUsage),
    );
    this.geometry.setAttribute('color', new THREE.BufferAttribute(this.colours, 3).setUsage(THREE.DynamicDrawUsage));
  }

  /**
   * Pack the scans of the visible robots, when due.
   * @param {import('./robot_view.js').RobotView[]} views @param {boolean} on the operator's Scans switch
   * @param {number} now ms
   */
  update(views, on, now) {
    if (this.points.visible !== on) {
      this.points.visible = on;
      this.changed = true;
    }
    if (!on || now - this.lastPack < 1000 / REPACK_HZ) return;
    let moved = this.changed;
    let total = 0;
    for (const view of views) {
      if (!view.group.visible) continue;
      total += view.scanCount;
      moved ||= view.scanCount > 0 && view.scanMoved();
    }
    if (!moved) return;
    this.lastPack = now;
    this.changed = false;
    this.#grow(Math.max(total, views.length * this.pointsPerRobot));
    const p = this.positions;
    const c = this.colours;
    let k = 0;
    for (const view of views) {
      const n = view.scanCount;
      if (!view.group.visible || n === 0) continue;
      const { x: ox, y: oy, z: oz } = view.group.position;
      const cos = Math.cos(view.yaw);
      const sin = Math.sin(view.yaw);
      const { r, g, b } = view.colour;
      const xy = view.scanXY;
      view.packedAt(ox, oz, view.yaw);
      for (let i = 0; i < n; i++, k++) {
        // Robot frame (x forward, y left) to the glTF frame (x, y up, -y), turned by the robot's yaw about +y.
        const a = xy[2 * i];
        const cz = -xy[2 * i + 1];
        p[3 * k] = ox + a * cos + cz * sin;
        p[3 * k + 1] = oy + HEIGHT;
        p[3 * k + 2] = oz - a * sin + cz * cos;
        c[3 * k] = r;
        c[3 * k + 1] = g;
        c[3 * k + 2] = b;
      }
    }
    this.drawn = k;
    this.geometry.setDrawRange(0, k);
    for (const name of ['position', 'color']) {
      const attribute = /** @type {THREE.BufferAttribute} */ (this.geometry.getAttribute(name));
      attribute.clearUpdateRanges();
      attribute.addUpdateRange(0, k * 3);
      attribute.needsUpdate = true;
    }
  }

  dispose() {
    this.points.removeFromParent();
    this.geometry.dispose();
    this.material.dispose();
  }
}
