// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { cleanName, displayName, MAX_NAME_LENGTH } from '../src/operator_names.js';

test('holders read as people: you, their name, a mission, or their id when they gave none', () => {
  const names = new Map([['c2-ab', 'Ana']]);
  assert.equal(displayName('c1-me', names, 'c1-me'), 'you');
  assert.equal(displayName('c2-ab', names, 'c1-me'), 'Ana');
  assert.equal(displayName('mission:m-3.robot1', names, 'c1-me'), 'a mission');
  assert.equal(displayName('c9-zz', names, 'c1-me'), 'c9-zz');
  assert.equal(displayName(null, names, 'c1-me'), '');
});

test('a name is trimmed and kept to letters, digits and a few marks; anything else is refused before sending', () => {
  assert.equal(cleanName("  Zoë   O'Neil "), "Zoë O'Neil");
  assert.equal(cleanName('Ops-2 (night)'), null);
  assert.equal(cleanName('<b>x</b>'), null);
  assert.equal(cleanName(''), null);
  assert.equal(cleanName('a'.repeat(MAX_NAME_LENGTH)), 'a'.repeat(MAX_NAME_LENGTH));
  assert.equal(cleanName('a'.repeat(MAX_NAME_LENGTH + 1)), null);
});
