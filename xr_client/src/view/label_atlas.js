// @ts-check
/**
 * Every robot's label in one texture and one draw call. Before, each robot had its own 512x150 canvas, texture and
 * sprite: 100 robots were 100 textures (30 MB uploaded whenever the labels changed, every second while the link
 * was lost, as they count the seconds) and 100 draw calls per eye. Here a single canvas holds a 256x75 cell per robot
 * (the cell is ~2x the label's 40 px on a Quest 3: sharp enough, and 100 cells are 2048x975, 8 MB once), and one
 * InstancedMesh of quads draws them all, each quad facing the viewer (the vertex shader turns it, in view space,
 * as a sprite is) with its cell's texture coordinates and its own opacity (label_rule.js: labels fade with distance).
 *
 * A label that changes is redrawn in its cell only, and only that cell is uploaded (texSubImage2D through
 * copyTextureToTexture), at most UPLOAD_HZ times a second: text the eye reads, not a per-pose refresh.
 */
import * as THREE from 'three';
import { AtlasLayout } from '../atlas_layout.js';
import { drawLabel } from './label_sprite.js';

export const CELL_WIDTH = 256;
export const CELL_HEIGHT = 75;
/** The label's width over its height (the cell's, 3.41 as the old 512x150 sprite's). */
export const LABEL_ASPECT = CELL_WIDTH / CELL_HEIGHT;
/** Uploads of changed cells, at most, per second. */
const UPLOAD_HZ = 4;
/** More changed cells than this share of the atlas: one upload of the whole texture instead of many small ones. */
const WHOLE_SHARE = 0.25;
/** Where the quad sits relative to its anchor, in label heights (a sprite's `center` of (0.5, -0.35)): above the
 * robot's top, beside the robot when seen from above, its footprint and heading left visible. */
export const LABEL_BOTTOM = 0.35;

const ORIGIN = new THREE.Vector3();

const VERTEX = /* glsl */ `
attribute vec4 cell;
attribute float opacity;
varying vec2 vUv;
varying float vOpacity;
void main() {
  vec4 anchor = modelViewMatrix * instanceMatrix * vec4(0.0, 0.0, 0.0, 1.0);
  vec2 size = vec2(length(instanceMatrix[0].xyz), length(instanceMatrix[1].xyz));
  anchor.xy += position.xy * size;
  gl_Position = projectionMatrix * anchor;
  vUv = vec2(mix(cell.x, cell.z, uv.x), mix(cell.w, cell.y, uv.y));
  vOpacity = opacity;
}`;

const FRAGMENT = /* glsl */ `
uniform sampler2D map;
varying vec2 vUv;
varying float vOpacity;
void main() {
  vec4 texel = texture2D(map, vUv);
  gl_FragColor = vec4(texel.rgb, texel.a * vOpacity);
  if (gl_FragColor.a < 0.004) discard;
  #include <colorspace_fragment>
}`;

export class LabelAtlas {
  /** @param {number} count labels (robots in the fleet) */
  constructor(count) {
    this.layout = new AtlasLayout(count, CELL_WIDTH, CELL_HEIGHT);
    this.canvas = document.createElement('canvas');
    this.canvas.width = this.layout.width;
    this.canvas.height = this.layout.height;
    this.ctx = /** @type {CanvasRenderingContext2D} */ (this.canvas.getContext('2d'));
    this.texture = new THREE.CanvasTexture(this.canvas);
    this.texture.colorSpace = THREE.SRGBColorSpace;
    // Not flipped: a cell's rows upload in canvas order, so one cell can be uploaded alone (atlas_layout.js's v).
    this.texture.flipY = false;
    this.texture.generateMipmaps = false;
    this.texture.minFilter = THREE.LinearFilter;
    /** The atlas as the source of partial uploads (never drawn, never uploaded itself). */
    this.source = new THREE.Texture(this.canvas);
    this.source.flipY = false;
    const plane = new THREE.PlaneGeometry(1, 1).translate(0, 0.5 + LABEL_BOTTOM, 0);
    const n = Math.max(1, this.layout.capacity);
    this.cells = new THREE.InstancedBufferAttribute(new Float32Array(n * 4), 4);
    this.opacities = new THREE.InstancedBufferAttribute(new Float32Array(n), 1).setUsage(THREE.DynamicDrawUsage);
    plane.setAttribute('cell', this.cells);
    plane.setAttribute('opacity', this.opacities);
    for (let i = 0; i < this.layout.capacity; i++) {
      const c = /** @type {import('../atlas_layout.js').Cell} */ (this.layout.cell(i));
      this.cells.setXYZW(i, c.u0, c.v0, c.u1, c.v1);
    }
    this.material = new THREE.ShaderMaterial({
      uniforms: { map: { value: this.texture } },
      vertexShader: VERTEX,
      fragmentShader: FRAGMENT,
      transparent: true,
      // On top of walls: the operator keeps track of every robot (an x-ray view of the twin).
      depthTest: false,
      depthWrite: false,
    });
    this.mesh = new THREE.InstancedMesh(plane, this.material, n);
    this.mesh.name = 'robot-labels';
    this.mesh.count = this.layout.capacity;
    this.mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    // Instances move every frame: the mesh's bounding sphere (computed once) would cull them wrongly.
    this.mesh.frustumCulled = false;
    this.mesh.renderOrder = 10;
    this.mesh.raycast = () => {}; // picked through each robot's invisible sprite (robot_view.js)
    /** Cells redrawn since the last upload. @type {Set<number>} */
    this.dirty = new Set();
    this.uploaded = false;
    this.lastUpload = -Infinity;
    /** Uploads done (whole atlas, single cells): the state snapshot reports them. */
    this.uploads = { whole: 0, cells: 0 };
    this.region = new THREE.Box2();
    this.position = new THREE.Vector2();
    this.matrix = new THREE.Matrix4();
    this.quaternion = new THREE.Quaternion();
    this.scale = new THREE.Vector3();
    for (let i = 0; i < this.layout.capacity; i++) this.place(i, null, 0, 0);
  }

  /**
   * Redraw one label in its cell (the upload follows in flush()).
   * @param {number} i @param {string[]} lines @param {import('./label_sprite.js').LabelStyle} style
   */
  draw(i, lines, style) {
    const c = this.layout.cell(i);
    if (!c) return;
    this.ctx.clearRect(c.x, c.y, c.w, c.h);
    drawLabel(this.ctx, c.x, c.y, c.w, c.h, lines, style);
    this.dirty.add(i);
  }

  /**
   * Where label i is drawn this frame: anchored at `anchor` (world), `height` metres high, `opacity` 0..1; a null
   * anchor or a zero opacity hides it.
   * @param {number} i @param {THREE.Vector3 | null} anchor @param {number} height @param {number} opacity
   */
  place(i, anchor, height, opacity) {
    if (i < 0 || i >= this.layout.capacity) return;
    const shown = anchor !== null && opacity > 0;
    this.scale.set(shown ? height * LABEL_ASPECT : 0, shown ? height : 0, 1);
    this.matrix.compose(anchor ?? ORIGIN, this.quaternion, this.scale);
    this.mesh.setMatrixAt(i, this.matrix);
    this.opacities.setX(i, shown ? opacity : 0);
  }

  /** After place() for this frame's labels: upload the instance data. */
  placed() {
    this.mesh.instanceMatrix.needsUpdate = true;
    this.opacities.needsUpdate = true;
  }

  /**
   * Upload what was redrawn: the whole atlas the first time (or when much changed), else each changed cell.
   * @param {THREE.WebGLRenderer | null} renderer @param {number} now ms
   */
  flush(renderer, now) {
    if (this.dirty.size === 0 || now - this.lastUpload < 1000 / UPLOAD_HZ) return;
    this.lastUpload = now;
    if (!this.uploaded || !renderer || this.dirty.size > WHOLE_SHARE * this.layout.capacity) {
      this.texture.needsUpdate = true;
      this.uploaded = true;
      this.uploads.whole++;
    } else {
      for (const i of this.dirty) {
        const c = /** @type {import('../atlas_layout.js').Cell} */ (this.layout.cell(i));
        this.region.min.set(c.x, c.y);
        this.region.max.set(c.x + c.w, c.y + c.h);
        renderer.copyTextureToTexture(this.source, this.texture, this.region, this.position.set(c.x, c.y));
        this.uploads.cells++;
      }
    }
    this.dirty.clear();
  }

  dispose() {
    this.mesh.removeFromParent();
    this.mesh.geometry.dispose();
    this.mesh.dispose();
    this.material.dispose();
    this.texture.dispose();
    this.source.dispose();
  }
}
