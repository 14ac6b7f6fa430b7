// @ts-check
/**
 * The controllers' buttons in VR, once per XR frame: the menu button (one press, one toggle), E-STOP on the lower
 * face button, push-to-talk on a thumbstick held in; and teleop stopped when the operator's inputs change between
 * hands and controllers.
 */
import { ButtonEdge } from '../menu_state.js';

/** xr-standard index of the upper face button (Y on the left controller, B on the right). */
export const MENU_BUTTON = 5;
/** xr-standard index of the lower face button (X on the left controller, A on the right): E-STOP, on either hand. */
export const ESTOP_BUTTON = 4;
/** A thumbstick pressed in and held: push-to-talk (view/voice_control.js). */
export const TALK_BUTTON = 3;

export class XRButtons {
  /**
   * @param {{xrInput: import('./xr_input.js').XRInput, menu: import('../menu_state.js').MenuState,
   *   actions: import('../app.js').OperatorActions}} host what the buttons read and drive
   */
  constructor(host) {
    this.host = host;
    /** @type {Map<number, ButtonEdge>} */
    this.menuEdges = new Map();
    /** @type {Map<number, ButtonEdge>} */
    this.estopEdges = new Map();
    /** Whether a thumbstick is held in (push-to-talk). */
    this.talking = false;
    /** What the operator's inputs are, hands or controllers, as last seen (null: not yet in VR). */
    /** @type {string | null} */
    this.inputKinds = null;
  }

  update() {
    const host = this.host;
    const input = host.xrInput;
    // 1. The menu button: a rising edge toggles, holding it does nothing more. X or A: E-STOP, at once, whatever
    // the menu or the tool (the menu's estop button: viewers are refused the same way).
    for (const slot of input.active()) {
      if (edgeOf(this.menuEdges, slot.index).update(input.pressed(slot, MENU_BUTTON))) host.actions.toggleMenu();
      if (edgeOf(this.estopEdges, slot.index).update(input.pressed(slot, ESTOP_BUTTON)))
        host.actions.pressMenu('estop');
    }
    // 1a. Hands and controllers may swap at any moment (the operator puts the controllers down): a robot driven by
    // the stick that went away must not keep the last command, so teleop stops at once, and says so.
    const kinds = [...new Set(input.active().map((slot) => (slot.source?.hand ? 'hands' : 'controllers')))]
      .sort()
      .join(' and ');
    if (this.inputKinds !== null && kinds !== this.inputKinds && host.menu.tool === 'teleop' && host.menu.selected) {
      host.actions.apply([{ type: 'stop_teleop', robot: host.menu.selected }]);
      host.actions.say(`teleop stopped: input changed to ${kinds || 'nothing'}`, true);
    }
    this.inputKinds = kinds;
    // 1b. Push-to-talk while either thumbstick is held in.
    const talking = input.active().some((slot) => input.pressed(slot, TALK_BUTTON));
    if (talking !== this.talking) {
      this.talking = talking;
      host.actions.talk(talking);
    }
  }

  dispose() {
    this.menuEdges.clear();
    this.estopEdges.clear();
  }
}

/** @param {Map<number, ButtonEdge>} edges @param {number} index */
function edgeOf(edges, index) {
  let edge = edges.get(index);
  if (!edge) edges.set(index, (edge = new ButtonEdge()));
  return edge;
}
