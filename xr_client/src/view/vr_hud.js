// @ts-check
/**
 * What VR adds around the operator: the toast under the view, the sensor panel on the left wrist with the E-STOP
 * button under it, the latched-estop banner at the top of the view, and the overview table (a miniature of the
 * twin with the live robots) in front of them when the session starts. It follows the session (shown when it
 * starts, taken off when it ends) and is released by dispose().
 */
import { Toast } from './label_sprite.js';
import { WristPanel } from './panels.js';
import { EstopView } from './estop_view.js';
import { MiniatureView } from './miniature_view.js';

export class VRHud {
  /**
   * @param {import('three').Camera} camera what the toast and the banner hang from
   * @param {import('three').Object3D} scene
   */
  constructor(camera, scene) {
    this.camera = camera;
    this.toast = new Toast(camera);
    this.wrist = new WristPanel();
    this.estop = new EstopView(camera);
    this.miniature = new MiniatureView();
    scene.add(this.miniature.group);
    /** The table is placed early in a session, once the headset's pose is known. */
    this.placeTable = false;
    this.waited = 0;
  }

  /**
   * One VR frame: the wrist panel rides on the left controller's grip or the left hand's wrist, and redraws when due;
   * the overview table follows the twin and the robots, shown in Free Roam when the menu's Overview is on.
   * @param {number} now ms @param {{carrier: import('three').Object3D, hand: boolean} | null} wrist what carries the
   *   panel: the left controller's grip or the left hand's wrist (xr_input.js)
   * @param {import('./sensor_drawing.js').SensorPanelData} data
   * @param {{twin: import('./twin_view.js').TwinView, voxels: import('./voxel_view.js').VoxelView,
   *   views: Map<string, import('./robot_view.js').RobotView>,
   *   cursor: {point: {x: number, y: number}, verdict: import('../goal_verdict.js').GoalVerdict} | null,
   *   transform: import('../frames.js').MapToScene, show: boolean}} overview
   */
  update(now, wrist, data, overview) {
    if (wrist && this.wrist.mesh.parent !== wrist.carrier) {
      wrist.carrier.add(this.wrist.mesh);
      this.wrist.mount(wrist.hand ? 'hand' : 'controller');
    }
    this.estop.attach(this.wrist.mesh);
    this.wrist.update(data);
    this.toast.update(now, true);
    const table = this.miniature;
    table.setTwin(overview.twin);
    table.follow(overview.voxels, overview.twin.group.visible);
    // The headset's pose reaches the camera with the session's first rendered frames: the table waits for it
    // (a few frames at most; 'local' spaces may report the head at the origin, hence the count).
    if (this.placeTable && (this.camera.position.lengthSq() > 1e-6 || ++this.waited > 5)) {
      table.place(this.camera);
      this.placeTable = false;
    } else if (overview.show && !this.placeTable && !table.group.visible) table.place(this.camera);
    table.group.visible = overview.show && !this.placeTable;
    table.update(overview.views, overview.cursor?.point ?? null, overview.cursor?.verdict ?? null, overview.transform);
  }

  /**
   * The session started: the banner shows if a stop is latched.
   * @param {import('../estop_banner.js').EstopBanner | null} banner
   */
  started(banner) {
    this.estop.show(banner, true);
    this.placeTable = true;
    this.waited = 0;
  }

  /** The session ended: nothing of it stays in the desktop's view. */
  ended() {
    this.wrist.mesh.removeFromParent();
    this.toast.update(0, false);
    this.estop.show(this.estop.shown, false);
    this.miniature.group.visible = false;
  }

  dispose() {
    this.toast.dispose();
    this.wrist.dispose();
    this.estop.dispose();
    this.miniature.dispose();
  }
}
