// @ts-check
/**
 * The immersive session and where it puts the operator: entering VR (with the reference space the browser
 * offers), the starting place, the seated offset, teleport and snap turn of the rig, and the rig's return to
 * the desktop view when the session ends.
 */
import * as THREE from 'three';
import { mapToScene, mapYawToScene } from '../frames.js';
import { SEATED_HEIGHT_OFFSET } from '../locomotion.js';

/** Eye height assumed when the browser cannot place the floor ('local' reference space), metres. */
const STANDING_EYE_HEIGHT = 1.6;

export class XRSessionController {
  /** @type {XRSession | null} */
  session = null;
  /** The seated offset currently applied to the rig, metres. */
  appliedSeat = 0;
  /** Eye height the rig adds when the browser has no 'local-floor' reference space, metres. */
  floorOffset = 0;

  /**
   * @param {THREE.WebGLRenderer} renderer
   * @param {THREE.Group} rig the operator: the camera and the controllers ride on it
   * @param {THREE.PerspectiveCamera} camera
   * @param {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
   *   plan: import('./twin_plan.js').TwinPlan}} models `plan`: where to start (the twin as a floor plan)
   * @param {(text: string) => void} onError
   */
  constructor(renderer, rig, camera, models, onError) {
    this.renderer = renderer;
    this.rig = rig;
    this.camera = camera;
    this.fleet = models.fleet;
    this.menu = models.menu;
    this.plan = models.plan;
    this.onError = onError;
  }

  get presenting() {
    return this.renderer.xr.isPresenting;
  }

  async enter() {
    if (this.session || !navigator.xr) return;
    try {
      const session = await navigator.xr.requestSession('immersive-vr', {
        optionalFeatures: ['local-floor', 'bounded-floor', 'hand-tracking'],
      });
      this.session = session;
      // local-floor puts the origin on the floor; a browser without it gets 'local' (origin at the head)
      // and the rig makes up a standing eye height.
      try {
        await session.requestReferenceSpace('local-floor');
        this.renderer.xr.setReferenceSpaceType('local-floor');
        this.floorOffset = 0;
      } catch {
        this.renderer.xr.setReferenceSpaceType('local');
        this.floorOffset = STANDING_EYE_HEIGHT;
      }
      await this.renderer.xr.setSession(session);
    } catch (error) {
      const session = this.session;
      this.session = null;
      session?.end().catch(() => {});
      this.onError(`could not enter VR: ${/** @type {Error} */ (error).message}`);
    }
  }

  /**
   * Start on a spot with room around it and open floor ahead, facing the fleet, the overview table's place free
   * (start_pose.js, on the twin's walls); before the twin is loaded, where the relay said (hello.vantage); without
   * either (no map, no robot yet), at the south edge of the map facing north.
   */
  placeAtStart() {
    const t = this.fleet.scene.mapToScene;
    const [minX, minY, maxX] = this.fleet.bounds ?? [-2, -2, 2];
    const start = this.plan.start() ?? this.fleet.vantage ?? { x: (minX + maxX) / 2, y: minY + 0.3, yaw: Math.PI / 2 };
    const [x, , z] = mapToScene(t, start.x, start.y);
    this.appliedSeat = this.menu.options.seated ? SEATED_HEIGHT_OFFSET : 0;
    this.rig.position.set(x, this.appliedSeat + this.floorOffset, z);
    // The camera looks down its -z; a map yaw turns into the scene's yaw about +y, less the quarter turn between.
    this.rig.rotation.y = mapYawToScene(t, start.yaw) - Math.PI / 2;
    this.camera.position.set(0, 0, 0);
    this.camera.quaternion.identity();
  }

  /** The session ended: the rig goes back to the origin (the desktop camera is the app's to restore). */
  ended() {
    this.session = null;
    this.rig.position.set(0, 0, 0);
    this.rig.rotation.set(0, 0, 0);
  }

  /** Seated: the world is lowered under the operator (the rig raised) by a fixed amount. */
  updateSeat() {
    const seat = this.menu.options.seated ? SEATED_HEIGHT_OFFSET : 0;
    if (seat !== this.appliedSeat) {
      this.rig.position.y += seat - this.appliedSeat;
      this.appliedSeat = seat;
    }
  }

  /** Teleport so that the head lands over the target. @param {THREE.Vector3} target @param {THREE.Vector3} head */
  teleportTo(target, head) {
    this.rig.position.x += target.x - head.x;
    this.rig.position.z += target.z - head.z;
    this.rig.position.y = target.y + this.appliedSeat + this.floorOffset;
  }

  /** Snap turn about the head. @param {THREE.Vector3} head @param {number} angle */
  turnAbout(head, angle) {
    const offset = this.rig.position.clone().sub(head);
    offset.applyAxisAngle(new THREE.Vector3(0, 1, 0), angle);
    this.rig.position.set(head.x + offset.x, this.rig.position.y, head.z + offset.z);
    this.rig.rotation.y += angle;
  }

  dispose() {
    this.session?.end().catch(() => {});
  }
}
