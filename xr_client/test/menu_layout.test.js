// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { MenuState } from '../src/menu_state.js';
import { buttonAt, layoutMenu, MIN_BUTTON_W } from '../src/menu_layout.js';

test('every menu button gets a rectangle inside the panel, rows do not overlap, hits map back', () => {
  const menu = new MenuState();
  menu.setFleet(
    [
      { name: 'robot1', hasCamera: true },
      { name: 'robot2', hasCamera: false },
      { name: 'robot3', hasCamera: true },
    ],
    'operator',
  );
  const buttons = menu.buttons();
  const rects = layoutMenu(buttons, 1024, 700);
  assert.deepEqual(rects.map((r) => r.id).sort(), buttons.map((b) => b.id).sort());
  for (const r of rects) {
    assert.ok(r.x >= 0 && r.y >= 0 && r.x + r.w <= 1024 && r.y + r.h <= 700, JSON.stringify(r));
    assert.equal(buttonAt(rects, r.x + r.w / 2, r.y + r.h / 2), r.id);
    for (const o of rects) {
      if (o === r) continue;
      const overlap = r.x < o.x + o.w && o.x < r.x + r.w && r.y < o.y + o.h && o.y < r.y + r.h;
      assert.ok(!overlap, `${r.id} overlaps ${o.id}`);
    }
  }
  // E-STOP spans the last row, wider than any other button; with a robot selected, its own stop sits beside it.
  const estop = /** @type {import('../src/menu_layout.js').ButtonRect} */ (rects.find((r) => r.id === 'estop'));
  assert.ok(rects.every((r) => r.id === 'estop' || r.w < estop.w));
  assert.equal(buttonAt(rects, 2, 2), null);
  menu.press('robot:robot3');
  const withRobot = layoutMenu(menu.buttons(), 1024, 700);
  const big = /** @type {import('../src/menu_layout.js').ButtonRect} */ (withRobot.find((r) => r.id === 'estop'));
  const own = /** @type {import('../src/menu_layout.js').ButtonRect} */ (withRobot.find((r) => r.id === 'estop:robot'));
  assert.equal(own.y, big.y);
  assert.ok(Math.abs(big.w - 2 * own.w) < 1e-9 && rects.every((r) => r.id === 'estop' || r.w < big.w));
});

test('with twenty robots the robot row keeps six wide buttons, its pages a row of their own under it', () => {
  const menu = new MenuState();
  menu.setFleet(
    Array.from({ length: 20 }, (_, i) => ({ name: `robot${i + 1}`, hasCamera: false })),
    'operator',
  );
  menu.select('robot17');
  const buttons = menu.buttons();
  const rects = layoutMenu(buttons, 1024, 700);
  const rect = (/** @type {string} */ id) =>
    /** @type {import('../src/menu_layout.js').ButtonRect} */ (rects.find((r) => r.id === id));
  const robots = rects.filter((r) => r.id.startsWith('robot:'));
  assert.equal(robots.length, 6);
  // ~112 pixels for a name (panels.js draws a label 20 pixels narrower than its button): "robot100" in 26 px letters.
  assert.ok(
    robots.every((r) => r.w - 20 >= 110),
    JSON.stringify(robots),
  );
  const [prev, page, next] = [rect('robots:prev'), rect('robots:page'), rect('robots:next')];
  assert.ok(prev.y > robots[0].y + robots[0].h, 'the pages sit under the robots');
  assert.ok(prev.x < page.x && page.x < next.x && page.w > prev.w);
  assert.equal(buttonAt(rects, next.x + next.w / 2, next.y + next.h / 2), 'robots:next');
});

test('a row of more buttons than fit at the narrowest width wraps onto lines shared out evenly, on one grid', () => {
  const menu = new MenuState();
  menu.setFleet([{ name: 'robot1', hasCamera: true }], 'operator');
  const crowded = Array.from({ length: 8 }, (_, i) => ({
    id: `options:extra${i}`,
    group: 'options',
    label: `Option ${i}`,
    enabled: true,
    active: false,
  }));
  const buttons = [...menu.buttons().filter((b) => b.group !== 'options'), ...crowded];
  const rects = layoutMenu(/** @type {any} */ (buttons), 1024, 700);
  assert.deepEqual(rects.map((r) => r.id).sort(), buttons.map((b) => b.id).sort());
  assert.ok(
    rects.every((r) => r.w >= MIN_BUTTON_W && r.x + r.w <= 1024 && r.y + r.h <= 700),
    JSON.stringify(rects),
  );
  const options = rects.filter((r) => r.id.startsWith('options:'));
  const lines = [...new Set(options.map((r) => r.y))];
  assert.equal(lines.length, 2, 'eight buttons at 96 pixels each wrap onto two lines');
  assert.deepEqual(
    lines.map((y) => options.filter((r) => r.y === y).length),
    [4, 4],
  );
  // One grid: the second line's buttons stand under the first's.
  const [first, second] = lines.map((y) => options.filter((r) => r.y === y).map((r) => r.x));
  assert.deepEqual(first, second);
  for (const r of rects)
    for (const o of rects)
      if (o !== r)
        assert.ok(!(r.x < o.x + o.w && o.x < r.x + r.w && r.y < o.y + o.h && o.y < r.y + r.h), `${r.id}/${o.id}`);
});
