// @ts-check
/**
 * Goal markers: per robot, the goal it follows (or the one just sent), a ring with a heading arrow in the
 * robot's colour, the relay's error next to it, and the path its planner made (`<robot>/path`) until the goal
 * ends; plus the live pointer marker and arc while aiming, coloured by what a press would do.
 * Reads GoalPointer and GoalTracker; owns its geometry and disposes it.
 */
import * as THREE from 'three';
import { LabelSprite } from './label_sprite.js';
import { mapToScene, mapYawToScene } from '../frames.js';
import { verdictColour, verdictText } from '../goal_verdict.js';

const ARC_CAPACITY = 64;
/** The relay sends at most 400 points a path (relay/messages.py MAX_PATH_POINTS). */
const PATH_CAPACITY = 400;
/** Paths float a little over the floor, under the goal rings. */
const PATH_HEIGHT = 0.03;

class Marker {
  /** @param {THREE.ColorRepresentation} colour */
  constructor(colour) {
    this.group = new THREE.Group();
    this.ringGeometry = new THREE.RingGeometry(0.22, 0.3, 40).rotateX(-Math.PI / 2);
    this.arrowGeometry = new THREE.ShapeGeometry(
      new THREE.Shape([new THREE.Vector2(0.3, -0.09), new THREE.Vector2(0.62, 0), new THREE.Vector2(0.3, 0.09)]),
    ).rotateX(-Math.PI / 2);
    this.material = new THREE.MeshBasicMaterial({
      color: colour,
      side: THREE.DoubleSide,
      transparent: true,
      opacity: 0.9,
      depthWrite: false,
    });
    this.ring = new THREE.Mesh(this.ringGeometry, this.material);
    this.arrow = new THREE.Mesh(this.arrowGeometry, this.material);
    this.ring.position.y = this.arrow.position.y = 0.015;
    this.ring.raycast = this.arrow.raycast = () => {};
    this.group.add(this.ring, this.arrow);
    this.label = new LabelSprite({ width: 640, height: 128, worldHeight: 0.24 });
    this.label.sprite.position.set(0, 0.45, 0);
    this.label.sprite.visible = false;
    this.group.add(this.label.sprite);
    this.group.visible = false;
  }

  /**
   * @param {import('../frames.js').MapToScene} t
   * @param {{x: number, y: number, yaw: number | null}} goal
   * @param {string | null} text an error to show beside it
   * @param {number} [opacity] @param {string} [accent] the text's accent colour
   */
  show(t, goal, text, opacity = 0.9, accent = '#e02424') {
    const [x, y, z] = mapToScene(t, goal.x, goal.y, 0);
    this.group.position.set(x, y, z);
    this.arrow.visible = goal.yaw !== null;
    if (goal.yaw !== null) this.arrow.rotation.y = mapYawToScene(t, goal.yaw);
    this.material.opacity = opacity;
    this.label.sprite.visible = text !== null;
    if (text !== null) this.label.set(text.length > 60 ? [text.slice(0, 60), text.slice(60, 120)] : [text], { accent });
    this.group.visible = true;
  }

  hide() {
    this.group.visible = false;
  }

  dispose() {
    this.ringGeometry.dispose();
    this.arrowGeometry.dispose();
    this.material.dispose();
    this.label.dispose();
  }
}

export class GoalView {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'goals';
    /** @type {Map<string, Marker>} */
    this.markers = new Map();
    this.pointer = new Marker('#ffffff');
    this.group.add(this.pointer.group);
    this.arcPositions = new Float32Array(ARC_CAPACITY * 3);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(this.arcPositions, 3).setUsage(THREE.DynamicDrawUsage));
    this.arc = new THREE.Line(
      geometry,
      new THREE.LineBasicMaterial({ color: '#ffffff', transparent: true, opacity: 0.8 }),
    );
    this.arc.frustumCulled = false;
    this.arc.raycast = () => {};
    this.arc.visible = false;
    this.group.add(this.arc);
    /**
     * Each robot's planned path, in its colour; redrawn only when the relay sends a new one.
     * @type {Map<string, {line: THREE.Line, positions: Float32Array, source: number[][] | null}>}
     */
    this.paths = new Map();
  }

  /** @param {string} robot @param {string} colour */
  #path(robot, colour) {
    let path = this.paths.get(robot);
    if (!path) {
      const positions = new Float32Array(PATH_CAPACITY * 3);
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3).setUsage(THREE.DynamicDrawUsage));
      const line = new THREE.Line(
        geometry,
        new THREE.LineBasicMaterial({ color: colour, transparent: true, opacity: 0.85 }),
      );
      line.name = `path:${robot}`;
      line.frustumCulled = false;
      line.raycast = () => {};
      line.visible = false;
      this.group.add(line);
      this.paths.set(robot, (path = { line, positions, source: null }));
    }
    return path;
  }

  /** @param {string} robot @param {string} colour */
  #marker(robot, colour) {
    let marker = this.markers.get(robot);
    if (!marker) {
      marker = new Marker(colour);
      this.markers.set(robot, marker);
      this.group.add(marker.group);
    }
    return marker;
  }

  /**
   * @param {import('../fleet_model.js').FleetModel} fleet
   * @param {import('../goal_pointer.js').GoalTracker} goals
   * @param {number} now
   * @param {Map<string, number[][]>} [paths] each robot's planned path (map frame), while it has one
   */
  update(fleet, goals, now, paths = new Map()) {
    const t = fleet.scene.mapToScene;
    for (const [name, robot] of fleet.robots) {
      const points = paths.get(name) ?? null;
      const path = this.#path(name, robot.description.colour);
      if (points !== path.source) {
        path.source = points;
        setLine(path.line, path.positions, points && points.map(([x, y]) => mapToScene(t, x, y, PATH_HEIGHT)));
      }
    }
    for (const [name, robot] of fleet.robots) {
      const display = goals.display(name, now);
      const marker = this.#marker(name, robot.description.colour);
      if (!display) marker.hide();
      else {
        const text = display.error ? `${display.error.code}: ${display.error.message}` : null;
        marker.show(t, display.goal, text, display.state === 'pending' ? 0.5 : 0.9);
      }
    }
    for (const [name, marker] of this.markers) {
      if (!fleet.robots.has(name)) {
        marker.group.removeFromParent();
        marker.dispose();
        this.markers.delete(name);
      }
    }
    for (const [name, path] of this.paths) {
      if (!fleet.robots.has(name)) {
        disposeLine(path.line);
        this.paths.delete(name);
      }
    }
  }

  /**
   * The pointer: marker under the hit (heading while dragging) and the arc from the hand, both coloured by what a
   * press would do there, with the reason when it would do nothing (goal_verdict.js).
   * @param {import('../frames.js').MapToScene} t
   * @param {{x: number, y: number, yaw: number | null} | null} marker
   * @param {[number, number, number][] | null} arc
   * @param {import('../goal_verdict.js').GoalVerdict | null} [verdict]
   */
  setPointer(t, marker, arc, verdict = null) {
    const colour = verdict ? verdictColour(verdict) : '#ffffff';
    this.pointer.material.color.set(colour);
    /** @type {THREE.LineBasicMaterial} */ (this.arc.material).color.set(colour);
    if (marker)
      this.pointer.show(t, marker, verdictText(verdict), 0.95, verdict?.kind === 'select' ? '#ffffff' : '#e02424');
    else this.pointer.hide();
    setLine(this.arc, this.arcPositions, arc);
  }

  dispose() {
    for (const marker of this.markers.values()) marker.dispose();
    this.pointer.dispose();
    disposeLine(this.arc);
    for (const path of this.paths.values()) disposeLine(path.line);
    this.group.removeFromParent();
  }
}

/** @param {THREE.Line} line */
function disposeLine(line) {
  line.removeFromParent();
  line.geometry.dispose();
  /** @type {THREE.Material} */ (line.material).dispose();
}

/**
 * Write points into a fixed-capacity line (no new buffers per frame).
 * @param {THREE.Line} line @param {Float32Array} positions @param {[number, number, number][] | null} points
 */
export function setLine(line, positions, points) {
  if (!points || points.length < 2) {
    line.visible = false;
    return;
  }
  const n = Math.min(points.length, positions.length / 3);
  for (let i = 0; i < n; i++) positions.set(points[i], i * 3);
  line.geometry.setDrawRange(0, n);
  const attribute = /** @type {THREE.BufferAttribute} */ (line.geometry.getAttribute('position'));
  attribute.needsUpdate = true;
  line.visible = true;
}
