// @ts-check
/**
 * Signing in to a relay that has accounts (docs/security.md, "Accounts and roles"): the page's side of the routes
 * /whoami, /signin, /pair, /pair/claim and /signout. The session itself is an HttpOnly cookie the page never sees;
 * what the page keeps is the account and its CSRF token, which state-changing requests carry in a header. No DOM:
 * view/sign_in_dialog.js asks, station/account_flow.js decides when; test/sign_in.test.js drives these with a fake
 * fetch.
 */

/**
 * @typedef {{user: string, role: import('./protocol.js').Role, csrf: string}} Account
 * @typedef {{ok: true, account: Account} | {ok: false, reason: string}} SignInResult
 * @typedef {{account: Account | null | undefined, provider: string | null}} WhoAmI
 */

export const CSRF_HEADER = 'X-CSRF-Token';

/**
 * The relay's one answer about this page: who it is signed in as (`account`: an account, `null` when signed out on a
 * relay with accounts, `undefined` when the relay has none, the operator token as before, or cannot be asked) and
 * the site's OpenID Connect provider when the relay offers sign-in with it (`provider`: its issuer URL, else null).
 * One request answers both: a page asks once (station/account_flow.js), its sign-in dialog reuses the answer.
 * @param {string} origin @param {typeof fetch} [fetcher] @returns {Promise<WhoAmI>}
 */
export async function whoAmI(origin, fetcher = fetch) {
  try {
    const response = await fetcher(`${origin}/whoami`, { credentials: 'same-origin' });
    if (!response.ok) return { account: undefined, provider: null };
    const body = await response.json();
    const provider = typeof body?.oidc === 'string' ? body.oidc : null;
    if (body?.accounts !== true) return { account: undefined, provider };
    return { account: body.user === null ? null : account(body), provider };
  } catch {
    return { account: undefined, provider: null };
  }
}

/**
 * @param {string} origin @param {string} user @param {string} password @param {typeof fetch} [fetcher]
 * @returns {Promise<SignInResult>}
 */
export function signIn(origin, user, password, fetcher = fetch) {
  if (!user.trim() || !password) return Promise.resolve({ ok: false, reason: 'type your user name and password' });
  return post(origin, '/signin', { user: user.trim(), password }, null, fetcher);
}

/**
 * A headset's page takes the session of the person signed in on the desktop, by the code the desktop shows.
 * @param {string} origin @param {string} code @param {typeof fetch} [fetcher] @returns {Promise<SignInResult>}
 */
export function claimCode(origin, code, fetcher = fetch) {
  const cleaned = code.replace(/[\s-]/g, '').toUpperCase();
  if (cleaned.length !== 6) return Promise.resolve({ ok: false, reason: 'a pairing code has 6 letters and digits' });
  return post(origin, '/pair/claim', { code: cleaned }, null, fetcher);
}

/**
 * A pairing code for a headset, valid for `expiresIn` seconds, once.
 * @param {string} origin @param {Account} signedIn @param {typeof fetch} [fetcher]
 * @returns {Promise<{ok: true, code: string, expiresIn: number} | {ok: false, reason: string}>}
 */
export async function pairingCode(origin, signedIn, fetcher = fetch) {
  const answer = await send(origin, '/pair', {}, signedIn.csrf, fetcher);
  if (!answer.ok) return answer;
  const { code, expires_in: expiresIn } = answer.body;
  return typeof code === 'string' && typeof expiresIn === 'number'
    ? { ok: true, code, expiresIn }
    : { ok: false, reason: 'the relay answered something else' };
}

/** @param {string} origin @param {Account} signedIn @param {typeof fetch} [fetcher] */
export async function signOut(origin, signedIn, fetcher = fetch) {
  return (await send(origin, '/signout', {}, signedIn.csrf, fetcher)).ok;
}

/**
 * @param {string} origin @param {string} path @param {object} body @param {string | null} csrf
 * @param {typeof fetch} fetcher @returns {Promise<SignInResult>}
 */
async function post(origin, path, body, csrf, fetcher) {
  const answer = await send(origin, path, body, csrf, fetcher);
  if (!answer.ok) return answer;
  const signedIn = account(answer.body);
  return signedIn ? { ok: true, account: signedIn } : { ok: false, reason: 'the relay answered something else' };
}

/**
 * @param {string} origin @param {string} path @param {object} body @param {string | null} csrf
 * @param {typeof fetch} fetcher @returns {Promise<{ok: true, body: any} | {ok: false, reason: string}>}
 */
async function send(origin, path, body, csrf, fetcher) {
  /** @type {Record<string, string>} */
  const headers = { 'Content-Type': 'application/json' };
  if (csrf) headers[CSRF_HEADER] = csrf;
  try {
    const response = await fetcher(`${origin}${path}`, {
      method: 'POST',
      credentials: 'same-origin',
      headers,
      body: JSON.stringify(body),
    });
    if (!response.ok) return { ok: false, reason: (await response.text()).trim() || `HTTP ${response.status}` };
    return { ok: true, body: await response.json() };
  } catch {
    return { ok: false, reason: 'the relay cannot be reached' };
  }
}

/** @param {any} body @returns {Account | undefined} */
function account(body) {
  const roles = ['admin', 'operator', 'inspector', 'viewer'];
  if (!body || typeof body.user !== 'string' || typeof body.csrf !== 'string' || !roles.includes(body.role))
    return undefined;
  return { user: body.user, role: body.role, csrf: body.csrf };
}
