// @ts-check
/**
 * A model's meshes merged into one mesh per material, for drawing: the facility's 26 meshes (walls, panels, barrels,
 * pipes) share 11 materials, so the twin draws in 11 draw calls per eye instead of 26, and its overview-table copy too
 * (with 100 robots in VR, 52 of a frame's 95 objects were the twin and its copy; each draw call is ~10 us of
 * three.js on a 2-core machine, more on SwiftShader's side). The original stays in the scene, hidden, for what
 * needs its nodes: picking (a ray meets hidden meshes; the floor is found by name), bounds, the copy's source.
 */
import * as THREE from 'three';
import { mergeGeometries } from 'three/addons/utils/BufferGeometryUtils.js';

/**
 * The model's meshes baked into its parent's frame (the copy goes beside the model, or where a scaled parent puts
 * it) and merged by material: one mesh per material, sharing the model's materials (the caller frees only the
 * copy's geometries: disposeCopy). Attributes the materials do not read
 * are dropped so that any meshes merge (uv only for textured materials).
 * @param {THREE.Object3D} content
 * @returns {THREE.Group}
 */
export function mergedCopy(content) {
  content.updateWorldMatrix(true, true);
  const toParent = new THREE.Matrix4();
  if (content.parent) toParent.copy(content.parent.matrixWorld).invert();
  /** @type {Map<THREE.Material, THREE.BufferGeometry[]>} */
  const byMaterial = new Map();
  content.traverse((object) => {
    const mesh = /** @type {THREE.Mesh} */ (object);
    if (!mesh.isMesh || Array.isArray(mesh.material) || !mesh.visible) return;
    const material = mesh.material;
    const textured = Boolean(/** @type {THREE.MeshStandardMaterial} */ (material).map);
    let geometry = mesh.geometry.index ? mesh.geometry.toNonIndexed() : mesh.geometry.clone();
    for (const name of Object.keys(geometry.attributes)) {
      if (name !== 'position' && name !== 'normal' && !(textured && name === 'uv')) geometry.deleteAttribute(name);
    }
    geometry.morphAttributes = {};
    if (!geometry.getAttribute('normal')) geometry.computeVertexNormals();
    geometry.applyMatrix4(new THREE.Matrix4().multiplyMatrices(toParent, mesh.matrixWorld));
    if (textured && !geometry.getAttribute('uv'))
      geometry = geometry.setAttribute(
        'uv',
        new THREE.Float32BufferAttribute(new Float32Array(geometry.getAttribute('position').count * 2), 2),
      );
    let list = byMaterial.get(material);
    if (!list) byMaterial.set(material, (list = []));
    list.push(geometry);
  });
  const copy = new THREE.Group();
  copy.name = `${content.name || 'model'}-merged`;
  for (const [material, geometries] of byMaterial) {
    const merged = geometries.length === 1 ? geometries[0] : mergeGeometries(geometries);
    if (geometries.length > 1) for (const g of geometries) g.dispose();
    if (!merged) continue;
    const mesh = new THREE.Mesh(merged, material);
    mesh.name = `merged:${material.name || material.uuid}`;
    copy.add(mesh);
  }
  return copy;
}

/**
 * Free what mergedCopy allocated (its geometries; the materials are the model's). @param {THREE.Object3D | null} copy
 */
export function disposeCopy(copy) {
  copy?.removeFromParent();
  copy?.traverse((o) => /** @type {THREE.Mesh} */ (o).geometry?.dispose());
}
