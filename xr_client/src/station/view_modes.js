// @ts-check
/**
 * What the operator sees, by mode and display: Free Roam or Robot POV (the rig saved on the way in, given back on the
 * way out; the POV screen turned to where the head looked), on the desktop page or in the headset (the world hidden
 * in VR's Robot POV, the menu, HUD and desktop controls handed over as a session starts and ends).
 */
import * as THREE from 'three';
import { POV_LAYER } from '../view/hemisphere_screen.js';

export class ViewModes {
  /** @type {{position: THREE.Vector3, yaw: number} | null} where the operator was before Robot POV */
  savedRig = null;
  /** Where the head looked as Robot POV began: the POV screen's heading in VR (rad). */
  povYaw = 0;

  /**
   * @param {import('./stage.js').Stage} stage @param {import('./views.js').StationViews} views
   * @param {import('../menu_state.js').MenuState} menu
   */
  constructor(stage, views, menu) {
    this.stage = stage;
    this.views = views;
    this.menu = menu;
  }

  /** @param {import('../menu_state.js').Mode} mode */
  setMode(mode) {
    const { rig, camera } = this.stage;
    if (mode === 'pov') {
      this.savedRig = { position: rig.position.clone(), yaw: rig.rotation.y };
      // The user camera carries the head pose in VR too (three.js copies it there after each render,
      // relative to the rig); the XR camera's own matrixWorld would lose the rig.
      const forward = camera.getWorldDirection(new THREE.Vector3());
      this.povYaw = Math.atan2(-forward.x, -forward.z);
      this.views.desktop.pov.reset();
    } else if (this.savedRig) {
      // Free Roam returns the operator where they were.
      rig.position.copy(this.savedRig.position);
      rig.rotation.y = this.savedRig.yaw;
      this.savedRig = null;
    }
    this.apply();
  }

  /** World visibility and camera layers for the current mode and display. */
  apply() {
    const vrPov = this.stage.presenting && this.menu.mode === 'pov';
    this.stage.world.visible = !vrPov;
    this.views.hemisphere.group.visible = this.menu.mode === 'pov';
    if (vrPov) this.stage.camera.layers.enable(POV_LAYER);
    else this.stage.camera.layers.disable(POV_LAYER);
  }

  /** The headset takes over from the desktop page. */
  sessionStarted() {
    const views = this.views;
    views.desktop.suspend();
    this.stage.xrSession.placeAtStart();
    views.menuPanel.mesh.visible = this.menu.open;
    views.hud.started(views.overlay.banner);
    document.body.classList.add('presenting');
    this.apply();
  }

  /** The desktop page takes over again (teleop has already stopped: see App). */
  sessionEnded() {
    const views = this.views;
    this.stage.xrSession.ended();
    this.menu.setOpen(false);
    views.menuPanel.mesh.visible = false;
    views.menuPanel.tab.visible = false;
    views.hud.ended();
    views.xrInspection.update(false);
    views.desktop.resume();
    this.savedRig = null;
    document.body.classList.remove('presenting');
    this.apply();
  }
}
