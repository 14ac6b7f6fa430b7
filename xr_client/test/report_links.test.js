// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { reportLinks } from '../src/report_links.js';

test("the report and work orders of the finding's fleet mission, and the range page, carry the token", () => {
  const links = reportLinks('m-20261122-230112-ab12cd.robot1', 'a b&c');
  assert.deepEqual(
    links.map((l) => [l.text, l.href]),
    [
      ['Report', '/report/m-20261122-230112-ab12cd.html?token=a%20b%26c'],
      ['Work orders', '/report/m-20261122-230112-ab12cd.workorders.csv?token=a%20b%26c'],
      ['Range…', '/report/range.html?token=a%20b%26c'],
    ],
  );
});

test('without a mission only the range page; without a token no query', () => {
  assert.deepEqual(
    reportLinks(null, null).map((l) => l.href),
    ['/report/range.html'],
  );
  assert.deepEqual(
    reportLinks('m-1.robot2', null).map((l) => l.href),
    ['/report/m-1.html', '/report/m-1.workorders.csv', '/report/range.html'],
  );
});
