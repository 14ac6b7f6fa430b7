// @ts-check
/**
 * The station's one frame loop, for the desktop and for VR: each frame the held teleop command is confirmed, the
 * fleet, goals and the display's input and HUD are updated, and the stage is drawn (outside VR at most maxFps times a
 * second), with the JS time of each drawn frame recorded.
 */
import { HEADSET_PX_PER_RAD } from '../label_rule.js';
import * as THREE from 'three';
import { FrameTimer } from '../frame_timer.js';
import { ViewerPacer, viewerMessage } from '../viewer_pose.js';

const TIMING_SAMPLES = 1200;

/**
 * What a frame reads besides the stage and the views.
 * @typedef {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
 *   router: import('../message_router.js').MessageRouter, history: import('../sensor_history.js').SensorHistory,
 *   goals: import('../goal_pointer.js').GoalTracker, goalPointer: import('../goal_pointer.js').GoalPointer,
 *   driver: import('../teleop_driver.js').TeleopDriver, linkOk: () => boolean, povYaw: () => number,
 *   sensorPanelData: (now: number) => import('../view/sensor_drawing.js').SensorPanelData}} FrameHost
 */

export class FrameLoop {
  /** Drawn frames (the frame loop may skip drawing outside VR, see maxFps). */
  renders = 0;
  /** Frames run, drawn or not. */
  frameCount = 0;
  lastRender = -Infinity;
  /** When this page next tells the relay where its operator looks from. */
  viewer = new ViewerPacer();

  /**
   * @param {FrameHost} host @param {import('./stage.js').Stage} stage @param {import('./views.js').StationViews} views
   * @param {number | undefined} maxFps at most this many drawn frames a second outside VR (none: every frame)
   */
  constructor(host, stage, views, maxFps) {
    this.host = host;
    this.stage = stage;
    this.views = views;
    this.minFrameMs = maxFps ? 1000 / maxFps : 0;
    this.frameTimer = new FrameTimer(TIMING_SAMPLES);
    this.lastFrame = performance.now();
  }

  /** @param {number} _time @param {XRFrame | undefined} _frame */
  frame(_time, _frame) {
    const { fleet, menu, router, goalPointer } = this.host;
    const { stage, views } = this;
    const { camera } = stage;
    const hemisphere = views.hemisphere;
    const start = performance.now();
    const dt = Math.min(0.1, (start - this.lastFrame) / 1000);
    this.lastFrame = start;
    this.host.driver.tick(start); // confirms the held command to the socket worker once a frame, however slow
    const eye = camera.getWorldPosition(new THREE.Vector3());
    const link = !this.host.linkOk() ? 'lost' : router.linkStale(true, start) ? 'quiet' : 'live';
    stage.fleetView.update(start, {
      fleet,
      smoothers: router.smoothers,
      history: this.host.history,
      selected: menu.selected,
      eye,
      freshness: router.freshness,
      link,
      scans: menu.options.scans,
      // Labels keep 12-px lines: on the desktop's canvas as drawn, in a headset as a Quest 3 shows them.
      pxPerRad: stage.presenting
        ? HEADSET_PX_PER_RAD
        : stage.renderer.domElement.clientHeight / 2 / Math.tan((camera.fov * Math.PI) / 360),
      screen: stage.presenting
        ? xrScreen(stage.renderer.xr.getCamera())
        : { camera, width: stage.renderer.domElement.clientWidth, height: stage.renderer.domElement.clientHeight },
    });
    views.goalView.update(fleet, this.host.goals, start, router.paths);
    views.arms.update(router.arms.joints, stage.robotViews, dt);
    views.valve.update(router.arms.valve, fleet.scene.mapToScene);
    views.avatars.update(router.avatars.figures(fleet.scene.mapToScene));
    if (this.viewer.due(start)) this.#viewpoint(eye);
    stage.voxels.setVisible(menu.options.map3d);
    stage.twin.group.visible = menu.options.twin;
    if (stage.presenting) {
      views.armGrab.update(router.arms, start); // first: the holding hand's trigger is the gripper's, not a select
      views.interaction.update(start, dt);
      views.xrInspection.update(true);
      stage.xrSession.updateSeat();
      const overview = {
        twin: stage.twin,
        voxels: stage.voxels,
        views: stage.robotViews,
        cursor: views.interaction.goals.wimCursor,
        transform: fleet.scene.mapToScene,
        show: menu.options.overview && menu.mode === 'free_roam',
      };
      views.hud.update(start, views.xrInput.wrist('left'), this.host.sensorPanelData(start), overview);
      if (menu.mode === 'pov') {
        // The screen is centred on the eyes: a wide-angle image is only undistorted from its centre.
        camera.getWorldPosition(hemisphere.group.position);
        hemisphere.group.rotation.set(0, this.host.povYaw(), 0);
      }
    } else {
      views.armGrab.idle(); // left VR: no hand holds an arm, and its gripper's camera stops
      views.desktop.update(dt);
      views.goalView.setPointer(
        fleet.scene.mapToScene,
        menu.tool === 'goal' ? goalPointer.marker : null,
        null,
        goalPointer.verdict,
      );
    }
    views.overlay.update(start);
    // In VR every frame is drawn: the XR framebuffer is cleared before each frame (WebXR), so a skipped
    // frame would be a blank one.
    this.frameCount++;
    if (stage.presenting || start - this.lastRender >= this.minFrameMs - 1) {
      this.lastRender = start;
      stage.renderer.render(stage.scene, camera);
      if (!stage.presenting && menu.mode === 'pov')
        hemisphere.renderInto(stage.renderer, stage.scene, views.overlay.povRect(), views.desktop.pov.look);
      // JS time of drawn frames only (update + render calls): what the frame budget is about.
      this.frameTimer.record(performance.now() - start);
      this.renders++;
    }
  }

  /**
   * Where the operator looks from, for the session's recording (viewer_pose.js): the head, and in VR each hand's or
   * controller's ray; and what through (the desktop's view, Robot POV, the headset's world). Not before the relay's
   * `hello` (no fleet, no map frame yet), in a replay (its viewpoints are the recording's), nor while the link is down.
   * @param {THREE.Vector3} eye the camera's world position
   */
  #viewpoint(eye) {
    const { router, fleet } = this.host;
    if (router.hellos === 0 || router.playback || !this.host.linkOk()) return;
    const direction = this.stage.camera.getWorldDirection(new THREE.Vector3());
    /** @type {import('../viewer_pose.js').SceneHand[]} */
    const hands = [];
    if (this.stage.presenting) {
      for (const side of /** @type {const} */ (['left', 'right'])) {
        const slot = this.views.xrInput.side(side);
        if (!slot) continue;
        const ray = this.views.xrInput.ray(slot);
        hands.push({ hand: side, position: ray.origin.toArray(), direction: ray.direction.toArray() });
      }
    }
    const head = { position: eye.toArray(), direction: direction.toArray() };
    const { menu } = this.host;
    const through = this.stage.presenting ? 'free_roam' : this.views.desktop.views.mode;
    const message = viewerMessage(fleet.scene.mapToScene, head, hands, menu.mode === 'pov' ? 'pov' : through);
    if (message) this.views.send(message, false); // no id, no reply: the next goes a quarter of a second later
  }
}

/**
 * The picture labels are decluttered on in VR: the XR camera (three.js gives it the left eye's pose and projection,
 * as of the last frame drawn) and the left eye's viewport, in the XR framebuffer's pixels.
 * @param {THREE.ArrayCamera} xrCamera
 */
function xrScreen(xrCamera) {
  const viewport = xrCamera.cameras[0]?.viewport;
  return { camera: xrCamera, width: viewport?.z ?? 0, height: viewport?.w ?? 0 };
}
