// @ts-check
/**
 * The in-page sign-in dialog of a relay with accounts: user name and password, or a pairing code from a signed-in
 * desktop (a headset, where typing a password is slow). Opened without a modal backdrop, as every dialog of this
 * page (target_dialog.js), so E-STOP stays reachable; it stays open until the relay accepts, showing the relay's own
 * words when it does not ("wrong user name or password"). And the dialog that shows a pairing code.
 */
import { claimCode, signIn } from '../sign_in.js';

export class SignInDialog {
  /**
   * @param {HTMLDialogElement | null} element `#sign-in-dialog` of index.html
   * @param {string} origin the relay's @param {typeof fetch} [fetcher]
   */
  constructor(element, origin, fetcher = (...args) => fetch(...args)) {
    this.element = element;
    this.origin = origin;
    this.fetcher = fetcher;
    /** @type {((account: import('../sign_in.js').Account) => void) | null} */
    this.resolve = null;
    this.busy = false;
    this.onSubmit = (/** @type {Event} */ event) => {
      event.preventDefault(); // closed by an accepted answer only
      const value = /** @type {SubmitEvent} */ (event).submitter?.getAttribute('value');
      void this.#submit(value === 'pair' ? 'pair' : 'sign-in');
    };
    element?.querySelector('form')?.addEventListener('submit', this.onSubmit);
  }

  get open() {
    return Boolean(this.element?.open);
  }

  /**
   * Ask until the relay accepts; resolves with the account. @param {string} why the relay's refusal, shown first
   * @param {Promise<string | null>} provider the site's sign-in provider (issuer URL), as the page's one /whoami
   *   answered it (sign_in.js whoAmI): the dialog does not ask the relay again
   * @returns {Promise<import('../sign_in.js').Account>}
   */
  ask(why, provider) {
    const element = this.element;
    if (!element) return new Promise(() => {}); // no page: nobody to ask
    this.#error(why.replace(/^sign in:\s*/, ''));
    if (!element.open) element.show();
    void this.#offerProvider(element, provider);
    this.#field('user')?.focus();
    return new Promise((resolve) => (this.resolve = resolve));
  }

  /** The site's sign-in provider, when the relay has one: a link that leaves for it and comes back signed in. */
  async #offerProvider(/** @type {HTMLDialogElement} */ element, /** @type {Promise<string | null>} */ provider) {
    const link = /** @type {HTMLAnchorElement | null} */ (element.querySelector('a.oidc'));
    const issuer = link ? await provider : null;
    if (!link || !issuer) return;
    link.textContent = `Sign in with ${new URL(issuer).host}`;
    link.hidden = false;
  }

  /** @param {'sign-in' | 'pair'} how */
  async #submit(how) {
    if (this.busy) return;
    this.busy = true;
    this.#error(how === 'pair' ? 'pairing…' : 'signing in…');
    const answer =
      how === 'pair'
        ? await claimCode(this.origin, this.#field('code')?.value ?? '', this.fetcher)
        : await signIn(
            this.origin,
            this.#field('user')?.value ?? '',
            this.#field('password')?.value ?? '',
            this.fetcher,
          );
    this.busy = false;
    const password = this.#field('password');
    if (password) password.value = '';
    if (!answer.ok) {
      this.#error(answer.reason);
      return;
    }
    this.#error('');
    this.element?.close('ok');
    const resolve = this.resolve;
    this.resolve = null;
    resolve?.(answer.account);
  }

  /** @param {string} name @returns {HTMLInputElement | null} */
  #field(name) {
    return /** @type {HTMLInputElement | null} */ (this.element?.querySelector(`input[name="${name}"]`) ?? null);
  }

  /** @param {string} text */
  #error(text) {
    const line = this.element?.querySelector('.error');
    if (line) line.textContent = text;
  }

  dispose() {
    this.element?.querySelector('form')?.removeEventListener('submit', this.onSubmit);
  }
}

/**
 * Show a pairing code and when it expires, in `#pair-dialog`.
 * @param {HTMLDialogElement | null} element @param {string} code @param {number} expiresIn seconds
 */
export function showPairingCode(element, code, expiresIn) {
  if (!element) return;
  const shown = element.querySelector('.code');
  if (shown) shown.textContent = code;
  const expiry = element.querySelector('.expiry');
  if (expiry) expiry.textContent = `valid for ${Math.round(expiresIn / 60)} minutes, once`;
  if (!element.open) element.show();
}
