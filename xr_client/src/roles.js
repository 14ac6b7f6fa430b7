// @ts-check
/**
 * What this page's role may do, from the relay's own table (relay/accounts/roles.py, generated into protocol.js):
 * the page offers a person only what the relay would accept from them. An inspector stops robots and runs missions
 * but drives nothing by hand and resets no E-STOP; a viewer watches.
 */
import { ROLE_PERMISSIONS } from './protocol.js';

/** @typedef {'drive' | 'stop' | 'reset' | 'inspect' | 'users'} Permission */

/** @type {Record<string, readonly string[]>} */
const TABLE = ROLE_PERMISSIONS;

/** @param {import('./protocol.js').Role} role @param {Permission} permission */
export function may(role, permission) {
  return (TABLE[role] ?? []).includes(permission);
}
