// @ts-check
/**
 * The operator's options in the menu: how VR moves and what it shows (seated, smooth move, the overview table, the
 * scans, gaze press, a held arm's hand scale) and the station's sound (mute, volume, hazard ticks). No rule of the
 * menu depends on them; the views read them, and the menu's buttons flip them.
 */

/** The menu's volume buttons step in fifths of full volume. */
const VOLUME_STEPS = 5;

export class MenuOptions {
  /** The operator sits: the rig is raised by SEATED_HEIGHT_OFFSET (locomotion.js, view/xr_session.js). */
  seated = false;
  /** The left stick moves the operator smoothly (in free roam) instead of aiming a teleport. */
  smooth = false;
  /** VR's overview table (a miniature of the twin) in front of the operator. */
  overview = true;
  /** Laser scans drawn around the robots that have one (an RViz user expects them). */
  scans = true;
  /** The live 3D map from the robots' sensors drawn (view/voxel_view.js), when the relay streams one. */
  map3d = true;
  /** The facility's glTF twin drawn (off: the 3D map alone shows what the robots saw). */
  twin = true;
  /** Accessibility: resting the head's gaze on a menu button presses it (off: a dwell only marks image points). */
  dwellPress = false;
  /** The station's sounds off (view/sound_control.js follows it; its header button and M set it too). */
  muted = false;
  /** The sound's volume (0..1), shared with the header's slider (view/sound_control.js). */
  volume = 0.6;
  /** The selected robot's hazard ticks (the Geiger-like sonification), shared with the G key. */
  ticks = false;
  /** A held arm's gripper follows the whole of the hand's motion, not half of it (arm_grab.js). */
  handOneToOne = false;

  /**
   * An option's button (`opt:...`) was pressed: its switch flips, or the volume steps.
   * @param {string} id @returns {boolean} whether the button was an option's
   */
  press(id) {
    if (id === 'opt:seated') this.seated = !this.seated;
    else if (id === 'opt:smooth') this.smooth = !this.smooth;
    else if (id === 'opt:overview') this.overview = !this.overview;
    else if (id === 'opt:scans') this.scans = !this.scans;
    else if (id === 'opt:map3d') this.map3d = !this.map3d;
    else if (id === 'opt:twin') this.twin = !this.twin;
    else if (id === 'opt:dwell') this.dwellPress = !this.dwellPress;
    else if (id === 'opt:mute') this.muted = !this.muted;
    else if (id === 'opt:ticks') this.ticks = !this.ticks;
    else if (id === 'opt:hand') this.handOneToOne = !this.handOneToOne;
    else if (id === 'opt:volume-' || id === 'opt:volume+') {
      // Steps of a fifth, landing on them whatever the slider left (0.63 - a step is 0.4, not 0.43).
      const steps = Math.round(this.volume * VOLUME_STEPS) + (id === 'opt:volume+' ? 1 : -1);
      this.volume = Math.max(0, Math.min(VOLUME_STEPS, steps)) / VOLUME_STEPS;
    } else return false;
    return true;
  }
}
