// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { adoptMaterials, disposeModel } from '../src/view/model_materials.js';
import { TwinView } from '../src/view/twin_view.js';

/** A robot model as the loader caches it: a body and two wheels sharing one tyre material. */
function loadedRobot() {
  const body = new THREE.MeshStandardMaterial({ name: 'body', color: '#cccccc' });
  const tyre = new THREE.MeshStandardMaterial({ name: 'tyre', color: '#222222' });
  const scene = new THREE.Group();
  scene.add(new THREE.Mesh(new THREE.BoxGeometry(), body));
  scene.add(new THREE.Mesh(new THREE.CylinderGeometry(), tyre), new THREE.Mesh(new THREE.CylinderGeometry(), tyre));
  return { scene, body, tyre };
}

/** @param {THREE.Object3D} model */
function materialsOf(model) {
  /** @type {THREE.MeshStandardMaterial[]} */
  const found = [];
  model.traverse((o) => {
    const mesh = /** @type {THREE.Mesh} */ (o);
    if (mesh.isMesh) found.push(/** @type {THREE.MeshStandardMaterial} */ (mesh.material));
  });
  return found;
}

test('two robots from one loaded model own their materials: greying one leaves the other and the cache alone', () => {
  const loaded = loadedRobot();
  const first = loaded.scene.clone(true);
  const second = loaded.scene.clone(true);
  const owned = adoptMaterials(first, new THREE.Color('#e6194b'));
  adoptMaterials(second, new THREE.Color('#3cb44b'));
  assert.equal(owned.length, 2, 'one copy per distinct material: the two wheels still share theirs');
  // The first robot goes offline: every material it shows turns grey.
  for (const m of materialsOf(first)) m.color.setHex(0x808080);
  const [body2, wheel2] = materialsOf(second);
  assert.equal(body2.color.getHexString(), '3cb44b');
  assert.equal(wheel2.color.getHexString(), '222222');
  assert.equal(loaded.tyre.color.getHexString(), '222222');
  assert.equal(loaded.body.color.getHexString(), 'cccccc');
});

test('releasing a model frees its geometry, materials and textures', () => {
  const loaded = loadedRobot();
  loaded.body.map = new THREE.Texture();
  /** @type {string[]} */
  const freed = [];
  loaded.scene.traverse((o) => {
    const mesh = /** @type {THREE.Mesh} */ (o);
    if (mesh.isMesh) mesh.geometry.addEventListener('dispose', () => freed.push('geometry'));
  });
  loaded.body.addEventListener('dispose', () => freed.push('body'));
  loaded.tyre.addEventListener('dispose', () => freed.push('tyre'));
  loaded.body.map.addEventListener('dispose', () => freed.push('texture'));
  disposeModel(loaded.scene);
  assert.deepEqual(freed.filter((f) => f === 'geometry').length, 3);
  assert.ok(freed.includes('body') && freed.includes('tyre') && freed.includes('texture'));
});

test('a twin replaced by a newer map releases the old one from the loader', async () => {
  /** @type {string[]} */
  const released = [];
  const loader = {
    load: (/** @type {string} */ url) => Promise.resolve(/** @type {any} */ ({ scene: new THREE.Group(), url })),
    release: (/** @type {string} */ url) => void released.push(url),
  };
  const twin = new TwinView(/** @type {any} */ (loader));
  const mapToScene = { x: 0, y: 0, z: 0, yaw: 0 };
  twin.setScene({ url: '/scenes/generated/map-aaa.glb', mapToScene }, null);
  await Promise.resolve();
  twin.setScene({ url: '/scenes/generated/map-aaa.glb', mapToScene }, null);
  assert.deepEqual(released, [], 'the same twin again is kept');
  twin.setScene({ url: '/scenes/generated/map-bbb.glb', mapToScene }, null);
  assert.deepEqual(released, ['/scenes/generated/map-aaa.glb']);
  twin.dispose();
});
