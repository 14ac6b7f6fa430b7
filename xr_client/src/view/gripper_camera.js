// @ts-check
/**
 * The camera on a held arm's gripper (robots.yaml `arm.camera`: hello's camera with `on_arm`), in VR: while a hand
 * holds the arm, its picture is streamed (JPEG, GRIPPER_FPS) and shown on a small panel beside the gripper, turned to
 * the eyes, so that what the fingers are about to close on is seen from there; letting go stops the stream and hides
 * the panel. The frames come from the station's camera feed (view/camera_feed.js routes this camera's here) and are
 * decoded off the render path (view/frame_decoder.js).
 */
import * as THREE from 'three';
import { FrameDecoder } from './frame_decoder.js';

/** Pictures a second of the gripper's camera while the arm is held: enough to place the fingers. */
export const GRIPPER_FPS = 10;
/** The panel's size (m) and its height above the gripper (m): beside the hand, clear of the fingers. */
const PANEL_M = [0.16, 0.12];
const ABOVE_M = 0.12;
/** The texture the pictures are decoded to (px): the demo camera's own size. */
const TEXTURE_PX = { width: 320, height: 240 };

const world = new THREE.Vector3();

export class GripperCamera {
  /**
   * @param {{world: THREE.Object3D, camera: THREE.Camera,
   *   stream: (robot: string, camera: string, fps: number) => void}} host `stream`: ask the relay for a robot's
   *   camera at `fps` (0 stops it)
   */
  constructor(host) {
    this.host = host;
    /** The stream running: its robot, camera name and frames' identifier. */
    /** @type {{robot: string, camera: string, identifier: string} | null} */
    this.showing = null;
    this.frames = 0;
    this.texture = new THREE.Texture();
    this.texture.colorSpace = THREE.SRGBColorSpace;
    const material = new THREE.MeshBasicMaterial({ color: 0x202020, map: null, side: THREE.DoubleSide });
    this.mesh = new THREE.Mesh(new THREE.PlaneGeometry(PANEL_M[0], PANEL_M[1]), material);
    this.mesh.visible = false;
    this.mesh.renderOrder = 5;
    host.world.add(this.mesh);
    this.decoder = new FrameDecoder(
      () => TEXTURE_PX,
      (bitmap) => this.#show(bitmap),
    );
  }

  /**
   * Once a frame in VR: the arm of `robot` held (with the camera on it, `camera`: hello's description) or nothing
   * held; the gripper's position in the robot's body (its glTF frame) while held.
   * @param {string | null} robot @param {import('../protocol.js').CameraDescription | null} camera
   * @param {THREE.Object3D | undefined} body @param {number[] | undefined} tip the arm's tip, base link (x, y, z)
   */
  update(robot, camera, body, tip) {
    const wanted = robot && camera ? { robot, camera: camera.name, identifier: camera.identifier } : null;
    if (wanted?.identifier !== this.showing?.identifier) this.#switch(wanted);
    this.mesh.visible = this.showing !== null && body !== undefined && tip !== undefined;
    if (!this.mesh.visible || !body || !tip) return;
    body.localToWorld(world.set(tip[0], tip[2], -tip[1]));
    world.y += ABOVE_M;
    this.mesh.parent?.worldToLocal(this.mesh.position.copy(world));
    this.mesh.lookAt(this.host.camera.getWorldPosition(world));
  }

  /** What the state snapshot shows. */
  state() {
    return { visible: this.mesh.visible, identifier: this.showing?.identifier ?? null, frames: this.frames };
  }

  /** @param {{robot: string, camera: string, identifier: string} | null} wanted */
  #switch(wanted) {
    const was = this.showing;
    if (was) this.host.stream(was.robot, was.camera, 0);
    this.showing = wanted;
    this.frames = 0;
    const material = /** @type {THREE.MeshBasicMaterial} */ (this.mesh.material);
    material.map = null;
    material.color.set(0x202020);
    material.needsUpdate = true;
    this.decoder.setAccepted(wanted?.identifier ?? '');
    if (wanted) this.host.stream(wanted.robot, wanted.camera, GRIPPER_FPS);
  }

  /** @param {ImageBitmap} bitmap */
  #show(bitmap) {
    if (!this.showing) {
      bitmap.close();
      return;
    }
    const previous = /** @type {ImageBitmap | null} */ (this.texture.image);
    this.texture.image = bitmap;
    this.texture.needsUpdate = true;
    previous?.close?.();
    const material = /** @type {THREE.MeshBasicMaterial} */ (this.mesh.material);
    if (material.map !== this.texture) {
      material.map = this.texture;
      material.color.set(0xffffff);
      material.needsUpdate = true;
    }
    this.frames++;
  }

  dispose() {
    if (this.showing) this.host.stream(this.showing.robot, this.showing.camera, 0);
    this.mesh.removeFromParent();
    this.mesh.geometry.dispose();
    /** @type {THREE.MeshBasicMaterial} */ (this.mesh.material).dispose();
    this.texture.dispose();
  }
}
