// @ts-check
/**
 * The station's views on the stage, each built with a narrow host (the few objects and actions it needs, never the
 * App): goals and comfort, inspection, the VR HUD and menu panel, the hemisphere screen and its camera feed, voice and
 * sound, and the input of both displays (the headset's interaction, the desktop's controls). They also give the
 * station its one way to tell the operator something (notify). dispose() releases them all.
 */
import { ConfirmDialog } from '../view/confirm_dialog.js';
import { may } from '../roles.js';
import { operatorToken } from '../connection.js';
import { InspectionUi } from '../view/inspection_ui.js';
import { GoalView } from '../view/goal_view.js';
import { TeleportView, Vignette } from '../view/comfort_view.js';
import { HemisphereScreen } from '../view/hemisphere_screen.js';
import { CameraFeed } from '../view/camera_feed.js';
import { MenuPanel } from '../view/panels.js';
import { XRInput } from '../view/xr_input.js';
import { XRInteraction } from '../view/xr_interaction.js';
import { XRInspection } from '../view/xr_inspection.js';
import { FindingCard } from '../view/finding_card.js';
import { VRHud } from '../view/vr_hud.js';
import { OperatorUi } from '../view/operator_ui.js';
import { DesktopControls } from '../view/desktop_controls.js';
import { Overlay } from '../view/overlay.js';
import { fleetFacts } from '../robot_picker.js';
import { robotGroups } from '../robot_groups.js';
import { VoiceControl } from '../view/voice_control.js';
import { Dictation } from '../view/dictation.js';
import { SoundControl } from '../view/sound_control.js';
import { ArmViews } from '../view/arm_view.js';
import { ValveView } from '../view/valve_view.js';
import { XRArmGrab } from '../view/xr_arm_grab.js';
import { AvatarView } from '../view/avatar_view.js';
import { PlaybackBar } from '../view/playback_bar.js';
import { StudyPanel } from '../view/study_panel.js';

/**
 * What the views read and call besides the stage.
 * @typedef {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
 *   goals: import('../goal_pointer.js').GoalTracker, goalPointer: import('../goal_pointer.js').GoalPointer,
 *   sender: import('../command_sender.js').CommandSender, inspection: import('../inspection_model.js').InspectionModel,
 *   actions: import('../app.js').OperatorActions,
 *   goalFor: (robot: string, goal: import('../command_sender.js').Goal) => void, link: () => string,
 *   sensorPanelData: (now: number) => import('../view/sensor_drawing.js').SensorPanelData,
 *   povText: () => string, latency: import('../latency.js').Latency,
 *   study: import('../study_model.js').StudyModel, send: import('../command_sender.js').Link['send']}} ViewsHost
 */

export class StationViews {
  /** @param {import('./stage.js').Stage} stage @param {ViewsHost} host */
  constructor(stage, host) {
    const { scene, camera, rig, world, renderer, picking } = stage;
    const { fleet, menu, goalPointer, actions, sender } = host;
    const presenting = () => stage.presenting;
    /** Whether the headset shows the station (else the desktop page does). */
    this.presenting = presenting;
    this.goalView = new GoalView();
    /** Robots' arms, drawn from their joint states. */
    this.arms = new ArmViews();
    /** The facility's valve wheel, where and as far turned as the relay reports it. */
    this.valve = new ValveView();
    world.add(this.goalView.group, this.valve.group);
    /** A replayed session's operators among the robots. */
    this.avatars = new AvatarView();
    world.add(this.avatars.group);
    /** A replay's timeline in the page's header. */
    this.playbackBar = new PlaybackBar((command) => host.send(command));
    /** A message to the relay, as the connection sends it (null while disconnected: nothing queues). */
    this.send = host.send;
    this.teleportView = new TeleportView();
    world.add(this.teleportView.group);
    const token = operatorToken(window.location, window.sessionStorage);
    /** The page's own yes-or-no question (never window.confirm): removing a schedule, resetting an E-STOP. */
    this.confirm = new ConfirmDialog(
      /** @type {HTMLDialogElement | null} */ (document.getElementById('confirm-dialog')),
    );
    this.inspectionUi = new InspectionUi({
      world,
      model: host.inspection,
      sender,
      panel: document.getElementById('findings'),
      token,
      transform: () => fleet.scene.mapToScene,
      confirm: this.confirm,
    });
    this.vignette = new Vignette();
    camera.add(this.vignette.mesh);
    this.menuPanel = new MenuPanel();
    scene.add(this.menuPanel.mesh, this.menuPanel.tab);
    this.hud = new VRHud(camera, scene);
    this.operatorUi = new OperatorUi({
      sender,
      storage: window.localStorage,
      params: new URLSearchParams(location.search),
      presenting,
      sendGoal: host.goalFor,
    });
    this.hemisphere = new HemisphereScreen(640, 640);
    scene.add(this.hemisphere.group);
    // JPEG pictures and H.264 video onto the hemisphere; a fallback from video to JPEG is said once.
    this.feed = new CameraFeed({
      hemisphere: this.hemisphere,
      sender,
      say: (text) => this.notify(text, 'warning'),
      params: new URLSearchParams(location.search),
      latency: host.latency,
    });
    const inspection = host.inspection; // voice: its targets are places, its missions can be paused
    // Each team, and each room with robots in it now: the menu's group row and voice ("stop north crew") stop them.
    const groups = () =>
      robotGroups(
        [...fleet.robots.values()].map((r) => ({ name: r.description.name, team: r.description.team, pose: r.pose })),
        fleet.rooms,
      );
    this.voice = new VoiceControl({
      actions,
      menu,
      fleet,
      targets: () => [...inspection.targets.values()],
      activeMission: (r) => Boolean(inspection.active(r)),
      presenting,
      toast: (text) => this.notify(text, 'info'),
      groups,
    });
    this.sound = new SoundControl({
      fleet,
      menu,
      goals: host.goals,
      camera,
      robotViews: stage.robotViews,
      inputSources: () => renderer.xr.getSession()?.inputSources ?? [],
    });
    this.xrInput = new XRInput(renderer, rig, scene);
    /** The hand on the selected robot's arm (squeeze near its gripper). */
    this.armGrab = new XRArmGrab({
      input: this.xrInput,
      menu,
      robotViews: stage.robotViews,
      actions,
      world,
      camera,
      stream: (robot, name, fps) => sender.stream(robot, name, fps, fps > 0 ? 'jpeg' : undefined),
      armCamera: (robot) => fleet.robot(robot)?.description.cameras?.find((c) => c.on_arm) ?? null,
    });
    this.feed.also(this.armGrab.gripperCamera.decoder);
    /** A note dictated on the VR finding card (its Dictate button). */
    this.dictation = new Dictation((text) => this.notify(text, 'warning'));
    this.findingCard = new FindingCard(token);
    scene.add(this.findingCard.mesh);
    const inspect = new XRInspection({
      ui: this.inspectionUi,
      card: this.findingCard,
      picking,
      menu,
      camera,
      screen: this.hemisphere,
      notify: (text) => this.notify(text, 'info'),
      operator: () => may(menu.role, 'inspect') && menu.connected, // findings and targets: inspectors' too
      dictation: this.dictation,
    });
    this.xrInspection = inspect;
    this.interaction = new XRInteraction({
      xrInput: this.xrInput,
      camera,
      rig,
      menu,
      menuPanel: this.menuPanel,
      goalPointer,
      goalView: this.goalView,
      teleportView: this.teleportView,
      vignette: this.vignette,
      fleet,
      picking,
      actions,
      inspect,
      estop: this.hud.estop,
      miniature: this.hud.miniature,
      locomotion: stage.xrSession,
      link: host.link,
    });
    this.overlay = new Overlay({
      menu,
      actions,
      sensorPanelData: host.sensorPanelData,
      povText: host.povText,
      robotFacts: () => fleetFacts(fleet.robots.values(), (r) => inspection.progress(r), inspection.openAlerts()),
      groups: {
        menu,
        groups,
        // One E-STOP per robot of the group: the relay's own per-robot stop, each latched or refused as the menu's.
        stop: (robots) => robots.forEach((robot) => sender.estop(robot)),
        cancel: (robots) => robots.forEach((robot) => sender.cancel(robot)),
        chosen: (group) => this.inspectionUi.chooseGroup(group),
      },
    });
    const desktopHost = {
      camera,
      canvas: renderer.domElement,
      menu,
      goalPointer,
      picking,
      robotViews: stage.robotViews,
      actions,
      presenting,
      fleet,
      markPov: (/** @type {number} */ x, /** @type {number} */ y) => inspect.clickPov(x, y),
    };
    this.desktop = new DesktopControls(desktopHost, stage.container, this.overlay.povPanel);
    /** The study the relay runs, on the desktop page: instructions, time left, questionnaires, probes. */
    this.studyPanel = new StudyPanel(document.getElementById('study'), host.study, sender.link, (text) =>
      this.notify(text, 'error'),
    );
  }

  /**
   * The overlay's message line, and in VR a toast under the view (goal errors show at the marker instead).
   * @param {string} text @param {'info' | 'error' | 'warning'} kind @param {boolean} [toast]
   */
  notify(text, kind, toast = true) {
    this.overlay.say(text, kind);
    if (toast) this.hud.toast.say(text, kind, this.presenting(), performance.now());
  }

  dispose() {
    this.feed.dispose();
    this.sound.dispose();
    this.desktop.dispose();
    this.overlay.dispose();
    this.interaction.dispose();
    this.xrInput.dispose();
    this.goalView.dispose();
    this.arms.dispose();
    this.avatars.dispose();
    this.playbackBar.dispose();
    this.valve.dispose();
    this.armGrab.dispose();
    this.teleportView.dispose();
    this.vignette.dispose();
    this.menuPanel.dispose();
    this.hud.dispose();
    this.hemisphere.dispose();
    this.inspectionUi.dispose();
    this.confirm.dispose();
    this.findingCard.dispose();
    this.studyPanel.dispose();
  }
}
