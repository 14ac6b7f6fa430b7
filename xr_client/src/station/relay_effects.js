// @ts-check
/**
 * The relay's side of the station carried out: the link's state (the status line, and teleop stopped when nothing
 * can reach the relay) and each message routed (message_router.js decides) with its effects on the views: the fleet
 * and twin rebuilt, notices, scans, goals, E-STOP banners, take-over offers, inspection.
 */
import { may } from '../roles.js';
import { displayName } from '../operator_names.js';
import { estopBanner } from '../estop_banner.js';

/**
 * @typedef {{fleet: import('../fleet_model.js').FleetModel, menu: import('../menu_state.js').MenuState,
 *   router: import('../message_router.js').MessageRouter, connection: import('../connection.js').RelayConnection,
 *   driver: import('../teleop_driver.js').TeleopDriver}} RelayEffectsHost the behaviour the relay's effects touch
 */

export class RelayEffects {
  /** The desktop camera has framed the fleet (once; a reconnect keeps the operator's view). */
  framed = false;
  /** The status line: the link's state, and a replay's position. */
  linkText = 'connecting…';
  linkOk = false;

  /**
   * @param {RelayEffectsHost} host @param {import('./stage.js').Stage} stage
   * @param {import('./views.js').StationViews} views @param {import('./menu_effects.js').MenuEffects} menuEffects
   */
  constructor(host, stage, views, menuEffects) {
    this.host = host;
    this.stage = stage;
    this.views = views;
    this.menuEffects = menuEffects;
  }

  /** The connection's state changed, or a replay moved on. */
  onLink() {
    const { connection, router, menu } = this.host;
    const policy = connection.policy;
    const playback = router.playback;
    const paused = playback?.paused ? ' (paused)' : '';
    const replay = playback
      ? ` · replay ${playback.position.toFixed(1)} / ${playback.duration.toFixed(1)} s${paused}`
      : '';
    this.linkText = policy.describe(performance.now()) + (policy.state === 'connected' ? replay : '');
    this.linkOk = policy.state === 'connected';
    this.views.overlay.setLink(this.linkText, this.linkOk);
    this.views.playbackBar.show(policy.state === 'connected' ? playback : null);
    if (!this.linkOk && menu.connected) {
      // Nothing can reach the relay: stop locally (the relay's deadman stops the robot on its side).
      this.host.driver.stop(performance.now());
      menu.setConnected(false);
    }
  }

  /** A binary frame of the 3D map's block records. @param {ArrayBuffer} data */
  onVoxels(data) {
    try {
      this.host.router.voxels.frame(data);
    } catch (error) {
      console.warn(`3D map frame ignored: ${error instanceof Error ? error.message : error}`);
    }
    this.stage.voxels.schedule();
  }

  /** @param {import('../protocol.js').ServerMessage} message */
  onMessage(message) {
    for (const effect of this.host.router.route(message, performance.now())) this.#carryOut(effect);
  }

  /** Carry out what the router decided. @param {import('../message_router.js').RouterEffect} effect */
  #carryOut(effect) {
    const { fleet, menu } = this.host;
    const { stage, views } = this;
    switch (effect.type) {
      case 'fleet':
        this.#onFleet(effect.rebuild);
        break;
      case 'scene':
        stage.twin.setScene(fleet.scene, fleet.bounds);
        break;
      case 'notify':
        views.notify(effect.text, effect.kind, effect.toast);
        break;
      case 'stop_teleop':
        this.host.driver.stop(performance.now(), true);
        break;
      case 'cue':
        views.sound.cue({ kind: effect.kind, robot: effect.robot });
        break;
      case 'link':
        this.onLink();
        break;
      case 'model':
        stage.fleetView.rebuildOne(fleet, effect.robot);
        break;
      case 'scan':
        stage.robotViews.get(effect.robot)?.setScan(effect.scan);
        break;
      case 'goal_state':
        if (effect.robot === menu.selected) menu.show('goalActive', effect.active);
      // falls through: a status may also say who holds the robot now
      case 'names':
        this.menuEffects.syncHolder();
        break;
      case 'estop_state': {
        menu.setLatched(effect.latched);
        const robots = [...fleet.robots.keys()];
        const operator = may(fleet.role, 'reset');
        views.overlay.setBanner(
          estopBanner(effect.latched, robots, this.host.router.estopBy, fleet.clientId, operator, fleet.names),
        );
        views.hud.estop.show(views.overlay.banner, stage.presenting);
        break;
      }
      case 'arm_refused':
        views.armGrab.refused(effect.robot);
        break;
      case 'sensor_warning':
        // A strong pulse on the wrist that carries the panel.
        views.xrInput.pulse(views.xrInput.side('left'), 0.9, 250);
        break;
      case 'offer_takeover': {
        const holder = displayName(fleet.robot(effect.robot)?.status?.controller, fleet.names, fleet.clientId);
        views.operatorUi.offer(effect.robot, holder || 'another operator', effect.goal);
        break;
      }
      case 'inspection':
        views.inspectionUi.update(menu);
        break;
      case 'voxels':
        stage.voxels.schedule();
        break;
      case 'study': {
        views.studyPanel.update();
        // In the headset the question asked comes to the menu, opened for it (the page's panel is not seen there).
        const question = views.studyPanel.model.menuQuestion();
        if (question && !menu.question && stage.presenting && !menu.open) this.menuEffects.apply(menu.setOpen(true));
        menu.show('question', question);
        break;
      }
      case 'condition': // a study's condition starts: its sound set, what only the participant can do asked
        if (effect.muted !== null) views.sound.setMuted(effect.muted);
        if (effect.ask) views.notify(effect.ask, 'info');
        break;
      case 'nav':
        if (effect.mine || effect.robot === menu.selected) views.notify(effect.text, effect.kind);
        break;
    }
  }

  /** A `hello`: views for a new fleet, the twin, the first framing, the menu's robots. @param {boolean} rebuild */
  #onFleet(rebuild) {
    const { fleet, menu } = this.host;
    if (rebuild) this.stage.fleetView.rebuild(fleet);
    this.stage.twin.setScene(fleet.scene, fleet.bounds);
    if (!this.framed) {
      // Frame the fleet once; a reconnect leaves the operator's view alone.
      this.views.desktop.frameFleet();
      this.framed = true;
    }
    const robots = [...fleet.robots.values()].map((r) => ({
      name: r.description.name,
      hasCamera: (r.description.cameras ?? []).some((c) => !c.on_arm),
    }));
    this.menuEffects.apply(menu.setFleet(robots, fleet.role));
    this.menuEffects.syncSelection();
    this.views.operatorUi.hello(fleet.role !== 'viewer');
  }
}
