// @ts-check
/**
 * Accounts on the page (docs/security.md): when the relay refuses the connection asking to sign in, the sign-in
 * dialog opens, and once the relay accepts, the page connects again as that person (the session cookie goes with the
 * handshake). A signed-in page shows who it is in the header, with "Pair headset" (a code for the headset's page)
 * and "Sign out". A relay without accounts changes nothing: the operator token, as before.
 */
import { pairingCode, signOut, whoAmI } from '../sign_in.js';
import { showPairingCode, SignInDialog } from '../view/sign_in_dialog.js';

export class AccountFlow {
  /**
   * @param {{connection: import('../connection.js').RelayConnection, operatorUi: {signedIn: (user: string) => void},
   *   notify: (text: string) => void}} host
   * @param {Document} page @param {string} origin
   * @param {typeof fetch} [fetcher] the relay's routes are asked with it (test/account_flow.test.js counts them)
   */
  constructor(host, page, origin, fetcher = (...args) => fetch(...args)) {
    this.host = host;
    this.origin = origin;
    this.fetcher = fetcher;
    this.dialog = new SignInDialog(
      /** @type {HTMLDialogElement | null} */ (page.getElementById('sign-in-dialog')),
      origin,
      fetcher,
    );
    /** The relay's answer to /whoami, asked once a page: on load and by the sign-in dialog, whichever comes first
     * (a refused connection may open the dialog before the page's own question is answered).
     * @type {Promise<import('../sign_in.js').WhoAmI> | null} */
    this.whoami = null;
    this.pairDialog = /** @type {HTMLDialogElement | null} */ (page.getElementById('pair-dialog'));
    this.header = page.getElementById('account');
    /** @type {import('../sign_in.js').Account | null} */
    this.account = null;
    this.onStatus = () => this.#status();
    this.onClick = (/** @type {Event} */ event) => {
      const action = /** @type {HTMLElement} */ (event.target).closest('[data-account]')?.getAttribute('data-account');
      if (action === 'pair') void this.#pair();
      else if (action === 'sign-out') void this.#signOut();
    };
    host.connection.addEventListener('status', this.onStatus);
    this.header?.addEventListener('click', this.onClick);
  }

  /** A page reloaded keeps its cookie: learn who it is (the header, the name). */
  async start() {
    const { account } = await this.#whoAmI();
    if (account) this.#signedIn(account);
  }

  #whoAmI() {
    this.whoami ??= whoAmI(this.origin, this.fetcher);
    return this.whoami;
  }

  #status() {
    const policy = this.host.connection.policy;
    if (policy.state !== 'refused' || !policy.refusal.startsWith('sign in') || this.dialog.open) return;
    const provider = this.#whoAmI().then((answer) => answer.provider);
    void this.dialog.ask(policy.refusal, provider).then((account) => {
      this.#signedIn(account);
      this.host.connection.retry();
    });
  }

  /** @param {import('../sign_in.js').Account} account */
  #signedIn(account) {
    this.account = account;
    this.host.operatorUi.signedIn(account.user);
    if (!this.header) return;
    const who = this.header.querySelector('.who');
    if (who) who.textContent = `${account.user} (${account.role})`;
    this.header.hidden = false;
  }

  async #pair() {
    if (!this.account) return;
    const answer = await pairingCode(this.origin, this.account, this.fetcher);
    if (answer.ok) showPairingCode(this.pairDialog, answer.code, answer.expiresIn);
    else this.host.notify(`no pairing code: ${answer.reason}`);
  }

  async #signOut() {
    if (this.account && (await signOut(this.origin, this.account, this.fetcher))) location.reload();
  }

  dispose() {
    this.host.connection.removeEventListener('status', this.onStatus);
    this.header?.removeEventListener('click', this.onClick);
    this.dialog.dispose();
  }
}
