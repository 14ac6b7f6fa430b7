// @ts-check
/**
 * A replayed session's operators among the robots (avatar_model.js): each a head (a ball with a visor facing where
 * they looked), their hands, each hand's ray, and their name above. Geometry and materials are shared; a figure is
 * made when an operator first appears and kept while they stay; nothing is allocated per frame. dispose() releases
 * everything.
 */
import * as THREE from 'three';
import { LabelSprite } from './label_sprite.js';

const HEAD_RADIUS = 0.12; // m
const HAND_RADIUS = 0.04;
const RAY_LENGTH = 1.5; // m: enough to see where a hand pointed, short of the far wall
const COLOUR = '#7fdbff';
const FORWARD = new THREE.Vector3(0, 0, 1);
const direction = new THREE.Vector3();

/**
 * @typedef {{group: THREE.Group, head: THREE.Mesh, visor: THREE.Mesh, label: LabelSprite,
 *   hands: {ball: THREE.Mesh, ray: THREE.Line}[]}} Figure
 */

export class AvatarView {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'avatars';
    this.headGeometry = new THREE.SphereGeometry(HEAD_RADIUS, 20, 14);
    this.visorGeometry = new THREE.BoxGeometry(HEAD_RADIUS * 1.6, HEAD_RADIUS * 0.5, HEAD_RADIUS * 0.5);
    this.handGeometry = new THREE.SphereGeometry(HAND_RADIUS, 12, 8);
    this.rayGeometry = new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3(0, 0, 1)]);
    this.material = new THREE.MeshStandardMaterial({ color: COLOUR, roughness: 0.5, emissive: '#0b3a4a' });
    this.visorMaterial = new THREE.MeshStandardMaterial({ color: '#10161c', roughness: 0.3 });
    this.rayMaterial = new THREE.LineBasicMaterial({ color: COLOUR, transparent: true, opacity: 0.8 });
    /** @type {Map<string, Figure>} */
    this.figures = new Map();
  }

  /** Draw these operators (scene poses), and no others. @param {import('../avatar_model.js').AvatarFigure[]} shown */
  update(shown) {
    const seen = new Set();
    for (const avatar of shown) {
      seen.add(avatar.client);
      const figure = this.figures.get(avatar.client) ?? this.#figure(avatar.client);
      figure.group.visible = true;
      figure.group.position.fromArray(avatar.head.position);
      direction.fromArray(avatar.head.direction);
      figure.head.quaternion.setFromUnitVectors(FORWARD, direction);
      figure.label.set([avatar.label]);
      figure.hands.forEach((hand, k) => {
        const pose = avatar.hands[k];
        hand.ball.visible = hand.ray.visible = Boolean(pose);
        if (!pose) return;
        // Hands hang in the head's group: placed relative to it.
        hand.ball.position.fromArray(pose.position).sub(figure.group.position);
        hand.ray.position.copy(hand.ball.position);
        hand.ray.quaternion.setFromUnitVectors(FORWARD, direction.fromArray(pose.direction));
      });
    }
    for (const [client, figure] of this.figures) if (!seen.has(client)) figure.group.visible = false;
  }

  /** @param {string} client @returns {Figure} */
  #figure(client) {
    const group = new THREE.Group();
    group.name = `avatar-${client}`;
    const head = new THREE.Mesh(this.headGeometry, this.material);
    const visor = new THREE.Mesh(this.visorGeometry, this.visorMaterial);
    visor.position.set(0, HEAD_RADIUS * 0.15, HEAD_RADIUS * 0.75); // on the face: the head's +z looks
    head.add(visor);
    const label = new LabelSprite({ worldHeight: 0.3 });
    label.sprite.position.set(0, HEAD_RADIUS + 0.25, 0);
    group.add(head, label.sprite);
    const hands = [0, 1].map(() => {
      const ball = new THREE.Mesh(this.handGeometry, this.material);
      const ray = new THREE.Line(this.rayGeometry, this.rayMaterial);
      ray.scale.setScalar(RAY_LENGTH);
      group.add(ball, ray);
      return { ball, ray };
    });
    /** @type {Figure} */
    const figure = { group, head, visor, label, hands };
    this.figures.set(client, figure);
    this.group.add(group);
    return figure;
  }

  dispose() {
    for (const figure of this.figures.values()) figure.label.dispose();
    this.figures.clear();
    this.group.clear();
    this.headGeometry.dispose();
    this.visorGeometry.dispose();
    this.handGeometry.dispose();
    this.rayGeometry.dispose();
    this.material.dispose();
    this.visorMaterial.dispose();
    this.rayMaterial.dispose();
  }
}
