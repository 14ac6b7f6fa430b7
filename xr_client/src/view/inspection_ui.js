// @ts-check
/**
 * Inspection in the page: the targets and findings in the twin (InspectionView), the findings list on the desktop
 * (FindingsPanel), the operator's review both share (what is open, picked, proposed: InspectionReview), the
 * review's and the menu's mission buttons carried out as commands. The app calls `update` when the router reports
 * an inspection change and when the selection changes; the VR Inspect tool (xr_inspection.js) after each select.
 */
import { InspectionView } from './inspection_view.js';
import { FindingsPanel } from './findings_panel.js';
import { TargetDialog } from './target_dialog.js';
import { ScheduleForm } from './schedule_form.js';
import { InspectionReview, nextName } from '../inspection_review.js';
import { sinceLastRound } from '../change_colour.js';

export class InspectionUi {
  /**
   * @param {{world: import('three').Group, model: import('../inspection_model.js').InspectionModel,
   *   sender: import('../command_sender.js').CommandSender, panel: HTMLElement | null, token: string | null,
   *   transform: () => import('../frames.js').MapToScene, confirm: import('./confirm_dialog.js').ConfirmDialog}} parts
   *   `confirm`: the page's own yes-or-no question (the station's views own it: the E-STOP reset asks it too)
   */
  constructor(parts) {
    this.model = parts.model;
    this.sender = parts.sender;
    this.transform = parts.transform;
    this.review = new InspectionReview();
    this.view = new InspectionView(parts.world);
    /** Names a new target in the page (never window.prompt: it held the page, and E-STOP's keys with it). */
    this.names = new TargetDialog(/** @type {HTMLDialogElement | null} */ (document.getElementById('target-dialog')));
    /** Asks before a schedule is removed (never window.confirm, for the same reason). */
    this.confirm = parts.confirm;
    this.scheduleForm = parts.panel ? new ScheduleForm(parts.model, parts.sender, this.confirm) : null;
    this.panel = parts.panel
      ? new FindingsPanel(
          parts.panel,
          parts.model,
          this.review,
          (commands) => this.run(commands),
          parts.token,
          this.names,
          this.scheduleForm,
        )
      : null;
    if (this.panel) this.panel.onSince = (on) => this.sinceLastRound(on, this.menu);
  }

  /** @type {import('../menu_state.js').MenuState | null} the menu last updated: the panel's switch tells it too */
  menu = null;

  /**
   * Show only what changed since the last round (the menu's button, the panel's switch), or everything again.
   * @param {boolean} on @param {import('../menu_state.js').MenuState | null} menu
   */
  sinceLastRound(on, menu) {
    this.model.setSinceLastRound(on);
    if (menu) this.update(menu);
    else this.panel?.render();
  }

  /**
   * Send what the review decided (nothing queues while disconnected: a refused send changes nothing).
   * @param {import('../inspection_review.js').ReviewCommand[]} commands
   */
  run(commands) {
    const sender = this.sender;
    for (const c of commands) {
      if (c.type === 'finding_update') sender.findingUpdate(c.finding, c.fields);
      else if (c.type === 'target_at') sender.targetAt(c.target, c.x, c.y);
      else if (c.type === 'target_pixel') sender.targetFromPixel(c.target, c.capture, c.u, c.v);
      else if (c.type === 'target_live') {
        const request = sender.targetFromLive(c.target, c.robot, c.u, c.v);
        if (request) {
          this.model.await(String(request));
          this.review.liveAsked(String(request), c.target);
        }
      } else if (c.type === 'findings_page') {
        if (sender.findingsPage(c.before)) this.model.history = 'asked';
      } else if (c.type === 'alert_ack') {
        sender.alertAck(c.alert);
      } else if (c.type === 'mission_targets') {
        if (sender.missionTargets(c.targets, c.robot, c.robots)) this.review.picksSent();
      } else if (c.type === 'region') {
        const request = sender.region(c.capture, c.u, c.v);
        if (request) {
          this.model.await(String(request));
          this.review.regionAsked(String(request));
        }
      }
    }
  }

  /**
   * The desktop's group of robots chosen (view/group_bar.js), or null: the picked targets go to its robots alone.
   * @param {import('../robot_groups.js').RobotGroup | null} group
   */
  chooseGroup(group) {
    if (!this.panel) return;
    this.panel.group = group;
    this.panel.render();
  }

  /**
   * Redraw what changed, and tell the menu whether the selected robot is on a mission.
   * @param {import('../menu_state.js').MenuState} menu
   */
  update(menu) {
    this.menu = menu;
    this.review.sync(this.model);
    this.view.update(this.model, this.review, this.transform());
    if (this.panel) this.panel.robot = menu.selected;
    this.scheduleForm?.update(menu);
    this.panel?.render();
    const mission = menu.selected ? this.model.active(menu.selected) : null;
    menu.show('mission', mission ? /** @type {'running' | 'paused'} */ (mission.state) : null);
    menu.show('picked', this.review.picked.length);
    menu.show('alerts', this.model.openAlerts());
    menu.show('sinceLastRound', this.model.sinceLastRound);
    menu.show('changed', sinceLastRound(this.model.findings.values()).length);
  }

  /**
   * A mission button of the menu: the demo file; every target, for the selected robot or the fleet (a mission
   * made in VR as well as on the desktop); the targets picked in order; or the selected robot's mission paused,
   * resumed or aborted.
   * @param {{action: 'start' | 'all' | 'picked' | 'pause' | 'resume' | 'abort', robot: string | null}} effect
   * @param {import('../menu_state.js').MenuState} menu
   */
  command(effect, menu) {
    if (effect.action === 'start') {
      this.sender.missionStart('demo');
      return;
    }
    if (effect.action === 'picked') {
      this.run(this.review.startPicked(effect.robot));
      this.update(menu);
      return;
    }
    if (effect.action === 'all') {
      const targets = [...this.model.targets.keys()];
      if (targets.length) this.sender.missionTargets(targets, effect.robot);
      return;
    }
    const mission = effect.robot ? this.model.active(effect.robot) : null;
    if (mission) this.sender.mission(effect.action, mission.id);
  }

  /**
   * A new target at a map point the operator chose (shift-click on the twin's floor), named in a dialog.
   * @param {{x: number, y: number}} point
   */
  async addTarget(point) {
    const name = await this.names.ask(
      `Name of the new target at (${point.x.toFixed(1)}, ${point.y.toFixed(1)})`,
      nextName(this.model, 'target'),
    );
    if (name) this.run([{ type: 'target_at', target: name, x: point.x, y: point.y }]);
  }

  /** The selected robot's mission, one line for its panel ('' when it has none). @param {string | null} robot */
  progress(robot) {
    return robot ? this.model.progress(robot) : '';
  }

  dispose() {
    this.names.dispose();
    this.view.dispose();
  }
}
