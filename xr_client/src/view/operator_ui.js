// @ts-check
/**
 * Operators as people on the page: the name this operator goes by (asked once in an in-page dialog, remembered
 * in the browser, sent to the relay after every hello, or taken from `?name=`), and the in-page take-over dialog:
 * "robot1 is controlled by Ana. Take it over? It stops first." that, for a goal, sends the goal once the robot is
 * taken. No native confirm() or prompt(): they block the page (and the robots' teleop loop with it) and read like
 * a debugger. In VR the dialogs are not shown: the menu's Take over button does the same.
 */
import { cleanName, NAME_KEY } from '../operator_names.js';

export class OperatorUi {
  /**
   * @param {{sender: import('../command_sender.js').CommandSender, storage: Storage | null, params: URLSearchParams,
   *   presenting: () => boolean, sendGoal: (robot: string, goal: import('../command_sender.js').Goal) => void}} host
   */
  constructor(host) {
    this.host = host;
    this.nameDialog = /** @type {HTMLDialogElement | null} */ (document.getElementById('name-dialog'));
    this.takeoverDialog = /** @type {HTMLDialogElement | null} */ (document.getElementById('takeover-dialog'));
    /**
     * What accepting the open take-over dialog does.
     * @type {{robot: string, goal: import('../command_sender.js').Goal | null} | null}
     */
    this.offered = null;
    const fromUrl = cleanName(host.params.get('name') ?? '');
    if (fromUrl) host.storage?.setItem(NAME_KEY, fromUrl);
    /** @type {string | null} */
    this.name = cleanName(host.storage?.getItem(NAME_KEY) ?? '');
    /** The account this page signed in with, whose name the relay gives it (null: none). @type {string | null} */
    this.account = null;
    this.nameDialog?.addEventListener('submit', (event) => {
      // Later: asked again next visit.
      if (/** @type {SubmitEvent} */ (event).submitter?.getAttribute('value') === 'later') return;
      const input = /** @type {HTMLInputElement | null} */ (this.nameDialog?.querySelector('input'));
      const name = cleanName(input?.value ?? '');
      if (!name) {
        event.preventDefault();
        input?.setCustomValidity("letters, digits, spaces and . _ - ' only, at most 40");
        input?.reportValidity();
        return;
      }
      this.setName(name);
    });
    // Opened without a modal backdrop (the page's E-STOP stays clickable), so Esc is not the dialog's own: it cancels
    // here, and is the page's E-STOP as everywhere (desktop_controls.js).
    this.takeoverDialog?.addEventListener('keydown', (event) => {
      if (event.code === 'Escape') this.takeoverDialog?.close('cancel');
    });
    this.takeoverDialog?.addEventListener('close', () => {
      const offered = this.offered;
      this.offered = null;
      if (offered && this.takeoverDialog?.returnValue === 'take') this.#takeOver(offered.robot, offered.goal);
    });
  }

  /**
   * Signed in (account_flow.js): the account's name is this operator's, given by the relay; nothing is asked or
   * sent. @param {string} user
   */
  signedIn(user) {
    this.account = user;
    if (this.nameDialog?.open) this.nameDialog.close('later');
  }

  /** @param {string} name */
  setName(name) {
    this.name = name;
    this.host.storage?.setItem(NAME_KEY, name);
    this.host.sender.name(name);
  }

  /**
   * A hello: an operator without a name is asked once; a known name goes to the (new) relay. @param {boolean} operator
   */
  hello(operator) {
    if (this.account) return;
    if (this.name) this.host.sender.name(this.name);
    // Not modal: the station stays usable (and its E-STOP reachable) while the operator has not answered.
    else if (operator && !this.host.presenting() && this.nameDialog && !this.nameDialog.open) this.nameDialog.show();
  }

  /**
   * Offer to take a robot over from its holder (a refused goal, or the menu's Take over), in the page.
   * @param {string} robot @param {string} holder how the holder reads ("Ana", "a mission")
   * @param {import('../command_sender.js').Goal | null} goal the goal to send once the robot is taken, if any
   */
  offer(robot, holder, goal) {
    if (this.host.presenting() || !this.takeoverDialog) {
      this.#takeOver(robot, goal); // VR: the menu's Take over button was the explicit act
      return;
    }
    this.offered = { robot, goal };
    const text = this.takeoverDialog.querySelector('p');
    const then = holder === 'a mission' ? 'the mission pauses' : `${holder} is told`;
    if (text) text.textContent = `${robot} is controlled by ${holder}. Take it over? It stops first, and ${then}.`;
    const accept = /** @type {HTMLButtonElement | null} */ (this.takeoverDialog.querySelector('button[value="take"]'));
    if (accept) accept.textContent = goal ? `Take over and send ${robot} there` : `Take over ${robot}`;
    // Not modal: a modal dialog's backdrop would take the clicks meant for the menu's E-STOP while it waits.
    if (!this.takeoverDialog.open) this.takeoverDialog.show();
  }

  /** @param {string} robot @param {import('../command_sender.js').Goal | null} goal */
  #takeOver(robot, goal) {
    // The relay handles a client's frames in order: the lease is taken (the robot stopped) before the goal arrives.
    if (this.host.sender.takeOver(robot) && goal) this.host.sendGoal(robot, goal);
  }
}
