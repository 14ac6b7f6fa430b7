import { test } from 'node:test';
import assert from 'node:assert/strict';
import { setImmediate as settle } from 'node:timers/promises';

import { AccountFlow } from '../src/station/account_flow.js';

const ORIGIN = 'http://127.0.0.1:8080';
const ISSUER = 'https://id.site.example/realms/plant';

/** A relay with accounts that answers /whoami with `body`, counting every request by path. */
function relay(body) {
  const asked = [];
  const fetcher = async (url) => {
    asked.push(new URL(url).pathname);
    return { ok: true, status: 200, json: async () => body, text: async () => JSON.stringify(body) };
  };
  return { fetcher, whoami: () => asked.filter((path) => path === '/whoami').length };
}

/** The page's parts the flow touches: the sign-in dialog (its provider link), no account header. */
function page() {
  const link = { hidden: true, textContent: '' };
  const dialog = {
    open: false,
    show() {
      this.open = true;
    },
    querySelector: (selector) => (selector === 'a.oidc' ? link : null),
  };
  return { link, document: { getElementById: (id) => (id === 'sign-in-dialog' ? dialog : null) } };
}

/** A connection the relay refused, asking to sign in. */
function refused() {
  const connection = new EventTarget();
  Object.assign(connection, { policy: { state: 'refused', refusal: 'sign in: this relay has accounts' } });
  return connection;
}

for (const refusalFirst of [false, true]) {
  test(`a signed-out page asks /whoami once, its dialog offering the provider (refusal ${refusalFirst ? 'before' : 'after'} the answer)`, async () => {
    const { fetcher, whoami } = relay({ accounts: true, user: null, oidc: ISSUER });
    const { link, document } = page();
    const connection = refused();
    const flow = new AccountFlow(
      { connection, operatorUi: { signedIn: () => {} }, notify: () => {} },
      document,
      ORIGIN,
      fetcher,
    );
    if (refusalFirst) connection.dispatchEvent(new Event('status'));
    await flow.start();
    if (!refusalFirst) connection.dispatchEvent(new Event('status'));
    await settle();
    assert.equal(link.hidden, false);
    assert.equal(link.textContent, 'Sign in with id.site.example');
    assert.equal(whoami(), 1); // before: once on load and again when the dialog opened
    flow.dispose();
  });
}

test('a page reloaded signed in learns who it is with one /whoami', async () => {
  const { fetcher, whoami } = relay({ accounts: true, user: 'Ana', role: 'operator', csrf: 'tok-1' });
  const names = [];
  const connection = refused();
  const flow = new AccountFlow(
    { connection, operatorUi: { signedIn: (user) => names.push(user) }, notify: () => {} },
    page().document,
    ORIGIN,
    fetcher,
  );
  await flow.start();
  assert.deepEqual(names, ['Ana']);
  assert.equal(flow.account?.user, 'Ana');
  assert.equal(whoami(), 1);
  flow.dispose();
});
