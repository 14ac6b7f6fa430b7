// @ts-check
/**
 * The menu's effects carried out (menu_state.js decides them): the menu panel shown, the mode changed, the
 * selection followed (its camera on the POV screen, its teleop limits, who holds it), commands sent. Nothing queues
 * while disconnected (the sender refuses).
 */
import { displayName } from '../operator_names.js';

/** In VR a Reset E-STOP press is confirmed by a second press within this (ms): long enough to read the question,
 * and for a second press where frames come slowly (6 s was too short for an emulated headset on SwiftShader at a
 * frame a second: each press re-armed the question). Resetting stays a deliberate pair of presses. */
export const RESET_CONFIRM_MS = 15000;

/**
 * @typedef {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
 *   sender: import('../command_sender.js').CommandSender, driver: import('../teleop_driver.js').TeleopDriver,
 *   goalPointer: import('../goal_pointer.js').GoalPointer}} MenuEffectsHost the behaviour the effects touch
 */

export class MenuEffects {
  /**
   * @param {MenuEffectsHost} host @param {import('./views.js').StationViews} views
   * @param {import('./view_modes.js').ViewModes} modes
   */
  constructor(host, views, modes) {
    this.host = host;
    this.views = views;
    this.modes = modes;
    /** Until when (performance.now() ms) a second Reset E-STOP press in VR confirms the first: 0, none waits. */
    this.resetArmed = 0;
  }

  /** Carry out what the menu decided. @param {import('../menu_state.js').MenuEffect[]} effects */
  apply(effects) {
    const { fleet, menu, sender, driver } = this.host;
    const views = this.views;
    for (const effect of effects) {
      switch (effect.type) {
        case 'stop_teleop':
          driver.stop(performance.now());
          break;
        case 'menu':
          if (effect.open) views.interaction.placeMenu();
          views.menuPanel.mesh.visible = effect.open && views.presenting();
          break;
        case 'mode':
          this.modes.setMode(effect.mode);
          break;
        case 'select':
          this.syncSelection();
          break;
        case 'tool':
          this.host.goalPointer.cancel();
          break;
        case 'stream': {
          const camera = fleet.camera(effect.robot);
          if (camera) views.feed.stream(effect.robot, camera, effect.fps);
          break;
        }
        case 'snapshot':
          sender.snapshot(effect.robot, fleet.camera(effect.robot)?.name ?? null);
          break;
        case 'cancel':
          sender.cancel(effect.robot);
          break;
        case 'takeover':
          views.operatorUi.offer(effect.robot, effect.holder, null);
          break;
        case 'estop':
          driver.stop(performance.now(), true);
          sender.estop(effect.robot);
          break;
        case 'estop_reset':
          this.#askReset();
          break;
        case 'mission':
          views.inspectionUi.command(effect, menu);
          break;
        case 'alert_ack':
          sender.alertAck(effect.alert);
          break;
        case 'study_press': // a study's question answered in VR (the page's panel takes the same answers)
          views.studyPanel.pressMenu(effect.id);
          menu.show('question', views.studyPanel.model.menuQuestion());
          break;
        case 'since_last_round':
          views.inspectionUi.sinceLastRound(effect.on, menu);
          break;
      }
    }
  }

  /**
   * A reset asks first, naming whose E-STOP it lifts on which robots (estop_banner.js): on the desktop in the page's
   * own dialog (E-STOP stays clickable, Space and Esc still stop); in the headset, where no page dialog is seen, the
   * question comes as a notice and a second press of Reset E-STOP within RESET_CONFIRM_MS is the yes.
   */
  #askReset() {
    const { sender } = this.host;
    const question = this.views.overlay.banner?.question ?? 'Reset the E-STOP?';
    if (this.views.presenting()) {
      const now = performance.now();
      if (now <= this.resetArmed) {
        this.resetArmed = 0;
        sender.estopReset();
      } else {
        this.resetArmed = now + RESET_CONFIRM_MS;
        this.views.notify(`${question} Press Reset E-STOP again to confirm.`, 'warning');
      }
      return;
    }
    void this.views.confirm.ask(question, 'Reset E-STOP').then((yes) => {
      if (yes) sender.estopReset();
    });
  }

  /** The selected robot's camera feeds the POV screen; its teleop limits apply. */
  syncSelection() {
    const { fleet, menu } = this.host;
    const { feed, hemisphere } = this.views;
    menu.show('goalActive', Boolean(fleet.robot(menu.selected)?.status?.goal));
    this.syncHolder();
    this.views.inspectionUi.update(menu);
    const camera = fleet.camera(menu.selected);
    const identifier = camera?.identifier ?? '';
    if (identifier !== feed.accept) {
      feed.setAccepted(identifier);
      hemisphere.clear(camera ? 'no image yet: Snapshot or Live' : 'this robot has no camera');
      hemisphere.calibration = camera ? { width: camera.width, height: camera.height } : null;
      if (camera) hemisphere.setSize(camera.width, camera.height);
      if (camera) hemisphere.setLens(camera.lens, camera.width, camera.height);
    }
    const robot = fleet.robot(menu.selected);
    this.host.driver.setRobot(
      robot?.description.name ?? null,
      robot?.description.limits ?? { linear: 0, angular: 0 },
      performance.now(),
    );
  }

  /** Who holds the selected robot, when not this operator: the menu turns Teleop off for it and offers Take over. */
  syncHolder() {
    const { fleet, menu } = this.host;
    const controller = fleet.robot(menu.selected)?.status?.controller;
    menu.setHolder(
      controller && controller !== fleet.clientId ? displayName(controller, fleet.names, fleet.clientId) : null,
    );
  }
}
