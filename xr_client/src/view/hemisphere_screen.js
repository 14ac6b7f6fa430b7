// @ts-check
/**
 * The hemisphere screen of Robot POV: a spherical cap seen from its centre, its UVs computed from the lens
 * model of the frames (lens.js), showing the selected robot's wide-angle image: the image centre straight
 * ahead, the rim at half the field of view.
 *
 * One texture of fixed size, without mipmaps (video does not need them, and generating them doubles the
 * frame time), is created once and reused for every frame: a decoded ImageBitmap (already flipped, see
 * FrameDecoder) replaces the texture's image and is uploaded in place (texSubImage2D); the previous bitmap
 * is closed at once. Never a new texture per frame. A decoded H.264 picture (a WebCodecs VideoFrame) goes into the
 * same texture the same way, no canvas in between: WebGL takes a VideoFrame as a texture source, and the frame is
 * closed as soon as it is uploaded (a decoder's frames are few; holding them stalls it). The screen pulls the newest
 * picture just before it is drawn (`pull`, set by view/camera_feed.js), so a frame is uploaded only when drawn.
 *
 * Why not three.js's VideoFrameTexture: it is a VideoTexture, which three.js re-allocates (texImage2D) on every
 * upload instead of writing into the texture's storage (texSubImage2D), and it would be a second texture beside
 * the JPEG one: the tests pin one texture, reused for every frame, whatever the codec.
 *
 * The cap lives on its own layer (POV_LAYER): the desktop's picture-in-picture camera sees only that
 * layer, the main desktop camera never does, and in VR the layer is switched on while in Robot POV.
 */
import * as THREE from 'three';
import { fieldHalfAngle, hemisphereGeometry, projectOptical } from '../lens.js';
import { font } from './canvas_text.js';

export const POV_LAYER = 5;
const RADIUS = 5;

export class HemisphereScreen {
  /** @param {number} width @param {number} height fixed texture size */
  constructor(width = 1024, height = 1024) {
    this.group = new THREE.Group();
    this.group.name = 'pov';
    this.group.visible = false;
    this.uploads = 0;
    this.width = 0;
    this.height = 0;
    this.placeholder = document.createElement('canvas');
    this.texture = this.#createTexture(width, height);
    this.material = new THREE.MeshBasicMaterial({ map: this.texture });
    // Directions outside the image (a pinhole's top and bottom, beyond a fisheye's field) stay black
    // instead of smearing the edge pixels.
    this.material.onBeforeCompile = (shader) => {
      shader.fragmentShader = shader.fragmentShader.replace(
        '#include <map_fragment>',
        '#include <map_fragment>\n' +
          'if (vMapUv.x < 0.0 || vMapUv.x > 1.0 || vMapUv.y < 0.0 || vMapUv.y > 1.0) diffuseColor.rgb = vec3(0.0);',
      );
    };
    this.geometry = new THREE.BufferGeometry();
    this.mesh = new THREE.Mesh(this.geometry, this.material);
    this.mesh.frustumCulled = false;
    this.mesh.layers.set(POV_LAYER);
    this.group.add(this.mesh);
    // A dim floor disc for orientation in the otherwise empty space.
    this.floorGeometry = new THREE.RingGeometry(0.25, 1.2, 48).rotateX(-Math.PI / 2);
    this.floorMaterial = new THREE.MeshBasicMaterial({ color: '#2a3140', transparent: true, opacity: 0.6 });
    const floor = new THREE.Mesh(this.floorGeometry, this.floorMaterial);
    floor.position.y = -1.5;
    floor.layers.set(POV_LAYER);
    this.group.add(floor);
    this.lensKey = '';
    /**
     * The lens the cap was built for, and the image size its intrinsics are in.
     * @type {{lens: import('../lens.js').Lens, width: number, height: number} | null}
     */
    this.lens = null;
    /** @type {ImageBitmap | VideoFrame | null} the picture on the texture (closed when replaced) */
    this.source = null;
    /** @type {(() => {frame: VideoFrame, header: import('../camera_frame.js').FrameHeader} | null) | null} */
    this.pull = null;
    // The newest decoded video picture goes onto the texture just before the screen is drawn (each eye in VR:
    // the second finds nothing new).
    this.mesh.onBeforeRender = () => {
      const next = this.pull?.();
      if (next) this.showVideo(next.frame, next.header);
    };
    this.lastSeq = 0;
    this.lastIdentifier = '';
    /** @type {{width: number, height: number} | null} the selected camera's configured size: K's pixels */
    this.calibration = null;
    /** The desktop's picture-in-picture camera: it sees only the screen's layer. */
    this.povCamera = new THREE.PerspectiveCamera(100, 4 / 3, 0.05, 50);
    this.povCamera.layers.set(POV_LAYER);
    this.group.add(this.povCamera);
    this.setLens({ model: 'equidistant', fov: 180 }, width, height);
  }

  /**
   * The texture every frame of a camera is uploaded into: created when a camera of another size is
   * selected, never per frame. Frames are decoded straight to this size.
   * @param {number} width @param {number} height
   */
  #createTexture(width, height) {
    this.width = width;
    this.height = height;
    this.placeholder.width = width;
    this.placeholder.height = height;
    drawPlaceholder(this.placeholder, 'no image yet: Snapshot or Live');
    /** @type {THREE.Texture<HTMLCanvasElement | ImageBitmap | VideoFrame>} */
    const texture = new THREE.Texture(/** @type {HTMLCanvasElement | ImageBitmap | VideoFrame} */ (this.placeholder));
    texture.colorSpace = THREE.SRGBColorSpace;
    texture.generateMipmaps = false;
    texture.minFilter = THREE.LinearFilter;
    texture.magFilter = THREE.LinearFilter;
    texture.needsUpdate = true;
    texture.onUpdate = () => {
      this.uploads++;
      // Uploaded: the texture has the pixels, the decoder gets its frame back.
      if (typeof VideoFrame !== 'undefined' && texture.image instanceof VideoFrame) {
        texture.image.close();
        if (this.source === texture.image) this.source = null;
      }
    };
    return texture;
  }

  /**
   * Match the texture to the selected camera's size (capped at 2048 a side). A no-op when it already does.
   * @param {number} width @param {number} height
   */
  setSize(width, height) {
    const w = Math.max(16, Math.min(2048, Math.round(width)));
    const h = Math.max(16, Math.min(2048, Math.round(height)));
    if (w === this.width && h === this.height) return false;
    this.source?.close();
    this.source = null;
    this.texture.dispose();
    this.texture = this.#createTexture(w, h);
    this.material.map = this.texture;
    this.material.needsUpdate = true;
    return true;
  }

  /**
   * Rebuild the cap when the lens or the image proportions change (not per frame).
   * @param {import('../lens.js').Lens} lens @param {number} imageWidth @param {number} imageHeight
   */
  setLens(lens, imageWidth, imageHeight) {
    const key = JSON.stringify([lens, imageWidth, imageHeight]);
    if (key === this.lensKey) return;
    this.lensKey = key;
    this.lens = { lens, width: imageWidth, height: imageHeight };
    const { positions, uvs, indices } = hemisphereGeometry(lens, imageWidth, imageHeight, {
      radius: RADIUS,
      rings: 48,
      segments: 96,
    });
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute('uv', new THREE.BufferAttribute(uvs, 2));
    geometry.setIndex(new THREE.BufferAttribute(indices, 1));
    this.geometry.dispose();
    this.geometry = geometry;
    this.mesh.geometry = geometry;
  }

  /**
   * A decoded frame (width x height of this screen's texture, bottom-up).
   * @param {ImageBitmap} bitmap @param {import('../camera_frame.js').FrameHeader} header
   */
  show(bitmap, header) {
    // K of an OpenCV fisheye is in pixels of the calibration image (the camera's configured size); the
    // circle models and pinhole scale with the image, whose own size the header gives.
    const size = header.lens.model === 'opencv_fisheye' && this.calibration ? this.calibration : header;
    this.setLens(header.lens, size.width, size.height);
    this.#replace(bitmap, header);
  }

  /**
   * A decoded video picture, top-down like the camera's image: WebGL flips it on upload (texture.flipY, as for
   * the placeholder canvas), unlike an ImageBitmap, which WebGL never flips and the JPEG path decodes flipped.
   * @param {VideoFrame} frame @param {import('../camera_frame.js').FrameHeader} header
   */
  showVideo(frame, header) {
    // A frame of another size than the texture (a camera that changed its resolution): a texture of its size,
    // once; texSubImage2D into storage of another size would fail.
    if (frame.displayWidth !== this.width || frame.displayHeight !== this.height)
      this.setSize(frame.displayWidth, frame.displayHeight);
    const size = header.lens.model === 'opencv_fisheye' && this.calibration ? this.calibration : header;
    this.setLens(header.lens, size.width, size.height);
    this.#replace(frame, header);
  }

  /** @param {ImageBitmap | VideoFrame} source @param {import('../camera_frame.js').FrameHeader} header */
  #replace(source, header) {
    const previous = this.source;
    this.source = source;
    this.texture.image = source;
    this.texture.needsUpdate = true;
    this.lastSeq = header.seq;
    this.lastIdentifier = header.identifier;
    // Uploaded at the next render or replaced before it: either way nobody needs the old one. (A VideoFrame
    // uploaded already was closed then: closing twice is harmless.)
    previous?.close();
  }

  /**
   * The pixel of the picture shown in a world direction from the screen's centre (where the eyes are in VR), in
   * pixels of the camera's configured size (what the relay's lens model takes), top-down; null when no picture is
   * shown or the direction is outside the image. The lens's exact projection, not the mesh's interpolated UVs.
   * @param {THREE.Vector3} direction world
   * @returns {[number, number] | null}
   */
  pixelAt(direction) {
    const shown = this.lens;
    if (!shown || !this.calibration || !this.lastIdentifier || !this.group.visible) return null;
    const local = direction
      .clone()
      .applyQuaternion(this.group.getWorldQuaternion(new THREE.Quaternion()).invert())
      .normalize();
    if (Math.acos(Math.max(-1, Math.min(1, -local.z))) > fieldHalfAngle(shown.lens)) return null;
    const [u, v] = projectOptical(shown.lens, local.x, -local.y, -local.z, shown.width, shown.height);
    if (!(u >= 0 && u < shown.width && v >= 0 && v < shown.height)) return null;
    return [(u * this.calibration.width) / shown.width, (v * this.calibration.height) / shown.height];
  }

  /** Back to the placeholder (another robot selected). @param {string} text */
  clear(text) {
    this.source?.close();
    this.source = null;
    drawPlaceholder(this.placeholder, text);
    this.texture.image = this.placeholder;
    this.texture.needsUpdate = true;
    this.lastIdentifier = '';
  }

  /**
   * The desktop's Robot POV panel: the screen seen from its centre, drawn into the panel's rectangle of the page.
   * @param {THREE.WebGLRenderer} renderer @param {THREE.Scene} scene
   * @param {DOMRect} rect the panel, in page pixels @param {{yaw: number, pitch: number, fov: number}} look
   */
  renderInto(renderer, scene, rect, look) {
    const canvas = renderer.domElement.getBoundingClientRect();
    if (rect.width < 2 || rect.height < 2) return;
    const x = rect.left - canvas.left;
    const y = canvas.bottom - rect.bottom;
    this.group.position.set(0, 0, 0);
    this.group.rotation.set(0, 0, 0);
    this.povCamera.position.set(0, 0, 0);
    this.povCamera.rotation.set(-look.pitch, -look.yaw, 0, 'YXZ');
    this.povCamera.fov = look.fov;
    this.povCamera.aspect = rect.width / rect.height;
    this.povCamera.updateProjectionMatrix();
    renderer.setScissorTest(true);
    renderer.setScissor(x, y, rect.width, rect.height);
    renderer.setViewport(x, y, rect.width, rect.height);
    renderer.render(scene, this.povCamera);
    renderer.setScissorTest(false);
    const size = renderer.getSize(new THREE.Vector2());
    renderer.setViewport(0, 0, size.x, size.y);
  }

  dispose() {
    this.mesh.onBeforeRender = () => {};
    this.pull = null;
    this.source?.close();
    this.texture.dispose();
    this.material.dispose();
    this.geometry.dispose();
    this.floorGeometry.dispose();
    this.floorMaterial.dispose();
    this.group.removeFromParent();
  }
}

/**
 * The picture shown while there is none: a dark disc and the reason, upright once uploaded.
 * @param {HTMLCanvasElement} canvas @param {string} text
 */
function drawPlaceholder(canvas, text) {
  const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
  ctx.fillStyle = '#10141c';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.strokeStyle = '#2c3444';
  ctx.lineWidth = canvas.width / 200;
  ctx.beginPath();
  ctx.arc(
    canvas.width / 2,
    canvas.height / 2,
    Math.min(canvas.width, canvas.height) / 2 - ctx.lineWidth,
    0,
    2 * Math.PI,
  );
  ctx.stroke();
  ctx.fillStyle = '#9aa5b8';
  ctx.font = font(canvas.width / 26);
  ctx.textAlign = 'center';
  ctx.textBaseline = 'middle';
  // A canvas is flipped on upload (texture.flipY), like the frames that are decoded flipped: upright.
  ctx.fillText(text, canvas.width / 2, canvas.height / 2);
}
