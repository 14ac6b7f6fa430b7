// @ts-check
/**
 * Robots share one loaded glTF (the loader caches it per URL), so a robot that changes a material (its colour,
 * the grey of offline) must own that material: every material of its clone is copied, never only the tinted
 * one. Otherwise one robot going offline greys the wheels of every robot.
 */
import * as THREE from 'three';

/**
 * Give a cloned model materials of its own, the one named `body` tinted with the robot's colour.
 * @param {THREE.Object3D} model a clone of a shared glTF scene
 * @param {THREE.Color} colour
 * @returns {THREE.Material[]} the copies, which the caller disposes
 */
export function adoptMaterials(model, colour) {
  /** @type {Map<THREE.Material, THREE.Material>} */
  const copies = new Map();
  model.traverse((object) => {
    const mesh = /** @type {THREE.Mesh} */ (object);
    if (!mesh.isMesh) return;
    const own = (/** @type {THREE.Material} */ m) => {
      let copy = copies.get(m);
      if (!copy) {
        copy = m.clone();
        if (m.name === 'body') /** @type {THREE.MeshStandardMaterial} */ (copy).color.copy(colour);
        copies.set(m, copy);
      }
      return copy;
    };
    mesh.material = Array.isArray(mesh.material) ? mesh.material.map(own) : own(mesh.material);
  });
  return [...copies.values()];
}

/**
 * Free what a loaded model holds on the GPU: geometries, materials and their textures.
 * @param {THREE.Object3D} root
 */
export function disposeModel(root) {
  root.traverse((object) => {
    const mesh = /** @type {THREE.Mesh} */ (object);
    mesh.geometry?.dispose();
    const materials = Array.isArray(mesh.material) ? mesh.material : mesh.material ? [mesh.material] : [];
    for (const material of materials) {
      for (const value of Object.values(material)) if (value instanceof THREE.Texture) value.dispose();
      material.dispose();
    }
  });
}
