// @ts-check
/**
 * A flat panel drawn on a 2D canvas: the VR menu, its tab and the wrist panel. The canvas is redrawn when
 * its content changes and the texture flagged for upload; everything here is released by dispose().
 */
import * as THREE from 'three';

export class CanvasPlane {
  /**
   * @param {[number, number]} pixels the canvas size
   * @param {[number, number]} metres the plane's size in the world
   * @param {string} name the mesh's name (tests and pickers find it by name)
   */
  constructor(pixels, metres, name) {
    this.canvas = document.createElement('canvas');
    [this.canvas.width, this.canvas.height] = pixels;
    this.texture = new THREE.CanvasTexture(this.canvas);
    this.texture.colorSpace = THREE.SRGBColorSpace;
    this.geometry = new THREE.PlaneGeometry(metres[0], metres[1]);
    this.material = new THREE.MeshBasicMaterial({ map: this.texture, transparent: true, depthWrite: false });
    this.mesh = new THREE.Mesh(this.geometry, this.material);
    this.mesh.name = name;
  }

  dispose() {
    this.texture.dispose();
    this.geometry.dispose();
    this.material.dispose();
  }
}
