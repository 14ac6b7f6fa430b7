// @ts-check
/**
 * Inspection in the page: the targets and findings in the twin (InspectionView), the findings list on the desktop
 * (FindingsPanel), and the menu's mission buttons carried out as commands. The app calls `update` when the router
 * reports an inspection change and when the selection changes.
 */
import { InspectionView } from './inspection_view.js';
import { FindingsPanel } from './findings_panel.js';

export class InspectionUi {
  /**
   * @param {{world: import('three').Group, model: import('../inspection_model.js').InspectionModel,
   *   sender: import('../command_sender.js').CommandSender, panel: HTMLElement | null, token: string | null,
   *   transform: () => import('../frames.js').MapToScene}} parts
   */
  constructor(parts) {
    this.model = parts.model;
    this.sender = parts.sender;
    this.transform = parts.transform;
    this.view = new InspectionView(parts.world);
    this.panel = parts.panel ? new FindingsPanel(parts.panel, parts.model, parts.sender, parts.token) : null;
  }

  /** Redraw what changed, and tell the menu whether the selected robot is on a mission. @param {import('../menu_state.js').MenuState} menu */
  update(menu) {
    this.view.update(this.model, this.transform());
    if (this.panel) this.panel.robot = menu.selected;
    this.panel?.render();
    const mission = menu.selected ? this.model.active(menu.selected) : null;
    menu.setMission(mission ? /** @type {'running' | 'paused'} */ (mission.state) : null);
  }

  /**
   * A mission button of the menu: the demo file; every target, for the selected robot or the fleet (a mission
   * made in VR as well as on the desktop); or the selected robot's mission paused, resumed or aborted.
   * @param {{action: 'start' | 'all' | 'pause' | 'resume' | 'abort', robot: string | null}} effect
   */
  command(effect) {
    if (effect.action === 'start') {
      this.sender.missionStart('demo');
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

  /** A new target at a map point the operator chose (shift-click on the twin's floor), named in a dialog. @param {{x: number, y: number}} point */
  addTarget(point) {
    const name = window.prompt(`Name of the new target at (${point.x.toFixed(1)}, ${point.y.toFixed(1)})`, `target-${this.model.targets.size + 1}`);
    if (name) this.sender.targetAt(name.trim().replace(/[^A-Za-z0-9_-]+/g, '-').slice(0, 64), point.x, point.y);
  }

  /** The selected robot's mission, one line for its panel ('' when it has none). @param {string | null} robot */
  progress(robot) {
    return robot ? this.model.progress(robot) : '';
  }

  dispose() {
    this.view.dispose();
  }
}
