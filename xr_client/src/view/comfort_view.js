// @ts-check
/**
 * Locomotion visuals: the teleport arc and target ring on the locomotion hand, and the comfort vignette
 * (a head-locked radial fade whose strength follows the rig's motion).
 */
import * as THREE from 'three';
import { setLine } from './goal_view.js';

export class TeleportView {
  constructor() {
    this.group = new THREE.Group();
    this.positions = new Float32Array(64 * 3);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(this.positions, 3).setUsage(THREE.DynamicDrawUsage));
    this.arc = new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: '#7fd3ff' }));
    this.arc.frustumCulled = false;
    this.arc.visible = false;
    this.ringGeometry = new THREE.RingGeometry(0.2, 0.26, 40).rotateX(-Math.PI / 2);
    this.ringMaterial = new THREE.MeshBasicMaterial({ color: '#7fd3ff', side: THREE.DoubleSide });
    this.target = new THREE.Mesh(this.ringGeometry, this.ringMaterial);
    this.target.visible = false;
    this.arc.raycast = this.target.raycast = () => {};
    this.group.add(this.arc, this.target);
  }

  /** @param {[number, number, number][] | null} points @param {[number, number, number] | null} hit */
  set(points, hit) {
    setLine(this.arc, this.positions, points);
    this.target.visible = hit !== null;
    if (hit) this.target.position.set(hit[0], hit[1] + 0.01, hit[2]);
  }

  dispose() {
    this.arc.geometry.dispose();
    /** @type {THREE.Material} */ (this.arc.material).dispose();
    this.ringGeometry.dispose();
    this.ringMaterial.dispose();
  }
}

export class Vignette {
  constructor() {
    this.geometry = new THREE.PlaneGeometry(1.2, 1.2);
    this.material = new THREE.ShaderMaterial({
      transparent: true,
      depthTest: false,
      depthWrite: false,
      uniforms: { strength: { value: 0 } },
      vertexShader:
        'varying vec2 vUv; ' +
        'void main() { vUv = uv; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
      fragmentShader:
        'uniform float strength; varying vec2 vUv;' +
        'void main() { float r = length(vUv - 0.5) * 2.0;' +
        ' float a = smoothstep(mix(1.2, 0.35, strength), mix(1.4, 0.75, strength), r) * strength;' +
        ' gl_FragColor = vec4(0.0, 0.0, 0.0, a); }',
    });
    this.mesh = new THREE.Mesh(this.geometry, this.material);
    this.mesh.position.z = -0.2; // a child of the camera, just beyond its near plane
    this.mesh.renderOrder = 100;
    this.mesh.frustumCulled = false;
    this.mesh.visible = false;
    this.mesh.raycast = () => {};
    this.strength = 0;
  }

  /** @param {number} strength 0..1 */
  set(strength) {
    this.strength = strength;
    this.material.uniforms.strength.value = strength;
    this.mesh.visible = strength > 0.02;
  }

  dispose() {
    this.geometry.dispose();
    this.material.dispose();
  }
}
