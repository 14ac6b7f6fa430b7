// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { InspectionModel } from '../src/inspection_model.js';
import { STATUS_COLOURS } from '../src/change_colour.js';
import { FINDING_STATUSES, InspectionReview, nextName, targetName } from '../src/inspection_review.js';
import { CARD_PX, cardHit, cardLayout, pixelToCard } from '../src/finding_card_layout.js';
import { MenuState } from '../src/menu_state.js';

/** @param {Partial<import('../src/protocol.js').FindingMessage>} fields @returns {import('../src/protocol.js').FindingMessage} */
function finding(fields) {
  return {
    identifier: 'finding',
    id: 'f-1',
    capture: 'c-1',
    mission: 'm-1.robot1',
    target: 'spill',
    robot: 'robot1',
    x: 1.8,
    y: 8.2,
    status: 'anomaly',
    note: 'gas 698.2 ppm (over 400 ppm)',
    source: 'rule',
    region: null,
    image: '/captures/ab.jpg',
    readings: { gas: 698.2 },
    created: 10,
    updated: 10,
    ...fields,
  };
}

/** @param {string[]} ids */
function targets(ids) {
  return {
    identifier: /** @type {'targets'} */ ('targets'),
    targets: ids.map((id) => ({ id, name: id, kind: 'gas', x: 1, y: 2, yaw: null })),
  };
}

test('targets are picked in order, unpicked by a second select, and sent once as one mission', () => {
  const model = new InspectionModel();
  model.apply(targets(['spill', 'panels', 'leak']));
  const review = new InspectionReview();
  review.togglePick('leak');
  review.togglePick('spill');
  review.togglePick('panels');
  review.togglePick('spill');
  assert.deepEqual(review.picked, ['leak', 'panels']);
  assert.deepEqual(review.startPicked('robot2'), [
    { type: 'mission_targets', targets: ['leak', 'panels'], robot: 'robot2', robots: null },
  ]);
  assert.deepEqual(review.startPicked(null)[0], {
    type: 'mission_targets',
    targets: ['leak', 'panels'],
    robot: null,
    robots: null,
  });
  review.picksSent();
  assert.deepEqual(review.startPicked(null), [], 'nothing picked: no mission');
  // A target the relay no longer has is unpicked.
  review.togglePick('panels');
  review.togglePick('leak');
  model.apply(targets(['spill', 'leak']));
  review.sync(model);
  assert.deepEqual(review.picked, ['leak']);
});

test('a region is asked at the selected pixel, proposed when its outline arrives, and kept only on accept', () => {
  const model = new InspectionModel();
  model.apply(finding({}));
  const review = new InspectionReview();
  assert.deepEqual(review.imageClick(model, 10, 20), [], 'no finding open: nothing');
  review.select('f-1');
  assert.deepEqual(review.imageClick(model, 240, 260), [{ type: 'region', capture: 'c-1', u: 240, v: 260 }]);
  assert.equal(review.judging, false, 'nothing to judge: a gaze resting on the image may mark there');
  review.regionAsked('r-7');
  assert.equal(review.hint(), 'segmenting…');
  review.sync(model);
  assert.equal(review.proposal, null, 'no outline yet');
  assert.equal(review.judging, true, 'asked: a glance at the image is not another point');
  const outline = [
    [200, 220],
    [280, 220],
    [280, 300],
    [200, 300],
  ];
  model.apply({ identifier: 'region', id: 'r-7', capture: 'c-1', outline });
  review.sync(model);
  assert.deepEqual(review.proposal, outline);
  assert.deepEqual(review.outline(model), outline, 'the proposal is drawn over the image');
  assert.equal(review.judging, true, 'proposed: the operator reads it before Accept or Redo');
  review.redo();
  assert.equal(review.outline(model), null, 'redo drops it; the finding had no region');
  assert.equal(review.judging, false);
  review.regionAsked('r-8');
  model.apply({ identifier: 'region', id: 'r-8', capture: 'c-1', outline });
  review.sync(model);
  assert.deepEqual(review.accept(), [{ type: 'finding_update', finding: 'f-1', fields: { region: outline } }]);
  assert.deepEqual(review.accept(), [], 'accepted once');
  assert.deepEqual(review.setStatus('ok'), [{ type: 'finding_update', finding: 'f-1', fields: { status: 'ok' } }]);
});

test('a click on the image makes a target there in target mode, named without a keyboard, then goes back to regions', () => {
  const model = new InspectionModel();
  model.apply(targets(['spill', 'spot-2']));
  model.apply(finding({}));
  const review = new InspectionReview();
  review.select('f-1');
  review.setImageAction('target');
  assert.deepEqual(review.imageClick(model, 5, 6), [
    { type: 'target_pixel', target: 'spot-3', capture: 'c-1', u: 5, v: 6 },
  ]);
  assert.equal(review.imageAction, 'region');
  assert.deepEqual(review.imageClick(model, 5, 6, { target: true, name: ' valve #4 ' }), [
    { type: 'target_pixel', target: 'valve-4', capture: 'c-1', u: 5, v: 6 },
  ]);
  assert.deepEqual(
    review.imageClick(model, 5, 6, { target: true, name: '###' }),
    [],
    'a name of nothing but symbols sends nothing',
  );
  assert.equal(targetName('a'.repeat(80)).length, 64);
  assert.equal(nextName(model, 'point'), 'point-3');
});

test('opening another finding, or losing the open one, drops the region being marked', () => {
  const model = new InspectionModel();
  model.apply(finding({}));
  model.apply(finding({ id: 'f-2', capture: 'c-2' }));
  const review = new InspectionReview();
  review.select('f-1');
  review.regionAsked('r-1');
  review.select('f-2');
  assert.equal(review.pending, null);
  model.reset();
  review.sync(model);
  assert.equal(review.selected, null, 'a new relay: the finding is gone, the card closes');
});

test('the card maps a ray hit to a capture pixel and back, keeps the aspect, and disables what a viewer cannot do', () => {
  const size = /** @type {[number, number]} */ ([480, 480]);
  const layout = cardLayout({
    status: 'anomaly',
    proposal: false,
    imageAction: 'region',
    operator: true,
    imageSize: size,
  });
  const image = /** @type {NonNullable<typeof layout.image>} */ (layout.image);
  assert.ok(Math.abs(image.w - image.h) < 1e-9, 'a square capture stays square');
  assert.ok(image.x >= 0 && image.x + image.w <= CARD_PX[0] && image.y + image.h <= CARD_PX[1]);
  const [px, py] = pixelToCard(image, size, 120, 360);
  const hit = cardHit(layout, size, px, py);
  assert.ok(hit && 'pixel' in hit);
  assert.ok(Math.abs(hit.pixel[0] - 120) < 1e-9 && Math.abs(hit.pixel[1] - 360) < 1e-9);
  // Buttons never overlap the image, and each is hit at its centre.
  for (const b of layout.buttons) {
    assert.ok(b.x > image.x + image.w, `${b.id} right of the image`);
    assert.deepEqual(cardHit(layout, size, b.x + b.w / 2, b.y + b.h / 2), { button: b.id });
  }
  assert.deepEqual(
    layout.buttons.filter((b) => b.active).map((b) => b.id),
    ['status:anomaly', 'image:region', 'card:image'],
  );
  const proposed = cardLayout({ status: 'ok', proposal: true, imageAction: 'region', operator: true, imageSize: size });
  assert.ok(proposed.buttons.some((b) => b.id === 'region:accept'));
  const viewer = cardLayout({ status: 'ok', proposal: false, imageAction: 'region', operator: false, imageSize: size });
  const ok = /** @type {import('../src/finding_card_layout.js').CardButton} */ (
    viewer.buttons.find((b) => b.id === 'status:ok')
  );
  assert.equal(cardHit(viewer, size, ok.x + 5, ok.y + 5), null, 'a viewer cannot set a status');
  const close = /** @type {import('../src/finding_card_layout.js').CardButton} */ (
    viewer.buttons.find((b) => b.id === 'card:close')
  );
  assert.deepEqual(cardHit(viewer, size, close.x + 5, close.y + 5), { button: 'card:close' });
  // A changed finding's Before and After: for a viewer too (they only show), the one showing active; none without.
  const changed = cardLayout({ ...viewerState(size), before: 'before' });
  const shown = changed.buttons.filter((b) => b.id === 'card:before' || b.id === 'card:after');
  assert.deepEqual(
    shown.map((b) => [b.id, b.active, b.enabled]),
    [
      ['card:after', false, true],
      ['card:before', true, true],
    ],
  );
  for (const b of shown) assert.deepEqual(cardHit(changed, size, b.x + b.w / 2, b.y + b.h / 2), { button: b.id });
  assert.ok(!viewer.buttons.some((b) => b.id === 'card:before'));
  // A wide capture is letterboxed: its rectangle keeps 16:9.
  const wide = /** @type {NonNullable<typeof layout.image>} */ (
    cardLayout({ status: 'ok', proposal: false, imageAction: 'region', operator: true, imageSize: [1280, 720] }).image
  );
  assert.ok(Math.abs(wide.w / wide.h - 16 / 9) < 1e-9);
  assert.equal(cardHit(layout, null, px, py), null, 'no image loaded: the image area is nothing yet');
  // The trend sits in the column between the last row of buttons and Close, overlapping neither, and is no button.
  const t = layout.trend;
  const rows = layout.buttons.filter((b) => b.id !== 'card:close');
  const lowest = Math.max(...rows.map((b) => b.y + b.h));
  const closing = /** @type {import('../src/finding_card_layout.js').CardButton} */ (
    layout.buttons.find((b) => b.id === 'card:close')
  );
  assert.ok(t.y >= lowest && t.y + t.h <= closing.y && t.h >= 100, JSON.stringify({ t, lowest, close: closing.y }));
  assert.ok(t.x > image.x + image.w && t.x + t.w <= CARD_PX[0]);
  assert.equal(cardHit(layout, size, t.x + t.w / 2, t.y + t.h / 2), null);
});

test('the menu offers Inspect in free roam to viewers too, and the picked targets as a mission', () => {
  const menu = new MenuState();
  menu.setFleet([{ name: 'robot1', hasCamera: true }], 'viewer');
  assert.equal(menu.buttons().find((b) => b.id === 'tool:inspect')?.enabled, true, 'viewers review findings');
  menu.press('tool:inspect');
  assert.equal(menu.tool, 'inspect');
  menu.setFleet([{ name: 'robot1', hasCamera: true }], 'operator');
  assert.equal(menu.tool, 'inspect', 'becoming an operator keeps the tool');
  assert.equal(
    menu.buttons().find((b) => b.id === 'mission:picked'),
    undefined,
    'nothing picked: no button',
  );
  menu.show('picked', 2);
  menu.press('robot:robot1');
  const button = menu.buttons().find((b) => b.id === 'mission:picked');
  assert.equal(button?.label, 'Inspect picked (2): robot1');
  assert.deepEqual(menu.press('mission:picked'), [{ type: 'mission', action: 'picked', robot: 'robot1' }]);
  // An estop stops motion tools only: the operator keeps reviewing.
  menu.press('estop');
  assert.equal(menu.tool, 'inspect');
  menu.press('mode:pov');
  assert.equal(menu.tool, 'inspect', 'in Robot POV, Inspect is the gaze on the live image');
  assert.equal(menu.buttons().find((b) => b.id === 'tool:inspect')?.label, 'Inspect (on the image)');
});

test('a point of the live image asks for a target there; its finding opens with the proposed region once the ack comes', () => {
  const model = new InspectionModel();
  model.apply(targets(['spill', 'spot-1']));
  const review = new InspectionReview();
  const [command] = review.liveClick(model, 'robot2', 300, 410);
  assert.deepEqual(
    command,
    { type: 'target_live', target: 'spot-3', robot: 'robot2', u: 300, v: 410 },
    'named without a keyboard',
  );
  model.await('r-9');
  review.liveAsked('r-9', 'spot-3');
  assert.deepEqual(review.liveClick(model, 'robot2', 10, 10), [], 'one at a time');
  // The relay's answer, in its order: targets, the finding, the region, then the ack.
  model.apply(targets(['spill', 'spot-1', 'spot-3']));
  model.apply(
    finding({
      id: 'f-9',
      capture: 'c-9',
      target: 'spot-3',
      robot: 'robot2',
      status: 'needs_review',
      source: 'operator',
      mission: null,
    }),
  );
  const outline = [
    [280, 390],
    [320, 390],
    [320, 430],
    [280, 430],
  ];
  model.apply({ identifier: 'region', id: 'r-9', capture: 'c-9', outline });
  review.sync(model);
  assert.equal(review.selected, null, 'nothing opens before the ack');
  assert.equal(model.settle('r-9', true), true);
  review.sync(model);
  assert.equal(review.selected, 'f-9');
  assert.deepEqual(review.proposal, outline);
  assert.deepEqual(review.accept(), [{ type: 'finding_update', finding: 'f-9', fields: { region: outline } }]);
  assert.equal(review.live, null);
  assert.equal(review.liveClick(model, 'robot2', 10, 10).length, 1, 'the next one may go');
});

test('a refused live target opens nothing, and a region answered without an outline says so and asks again', () => {
  const model = new InspectionModel();
  model.apply(finding({}));
  const review = new InspectionReview();
  model.await('r-1');
  review.liveAsked('r-1', 'spot-1');
  assert.equal(model.settle('r-1', false), true);
  review.sync(model);
  assert.equal(review.selected, null);
  assert.equal(review.live, null);
  assert.equal(model.settle('r-1', true), false, "answered once; other acks are not the review's");
  review.select('f-1');
  review.imageClick(model, 5, 5);
  model.await('r-2');
  review.regionAsked('r-2');
  model.settle('r-2', false);
  review.sync(model);
  assert.equal(review.pending, null);
  assert.match(review.hint(), /no region found there/);
  assert.deepEqual(review.imageClick(model, 240, 260), [{ type: 'region', capture: 'c-1', u: 240, v: 260 }]);
  assert.match(review.hint(), /select a point of the image to mark a region/, 'the note goes with the next point');
  // A new relay forgets what was awaited: a live target asked before it is not waited on forever.
  model.await('r-3');
  review.liveAsked('r-3', 'spot-2');
  model.reset();
  review.sync(model);
  assert.equal(review.live, null);
});

test('a change has a colour of its own, and a false alarm is marked with a note from the list or the card', () => {
  const colours = FINDING_STATUSES.map((s) => STATUS_COLOURS[s]);
  assert.equal(new Set(colours).size, FINDING_STATUSES.length, 'every status its own colour');
  assert.ok(![STATUS_COLOURS.anomaly, STATUS_COLOURS.needs_review].includes(STATUS_COLOURS.changed));
  const model = new InspectionModel();
  model.apply(finding({ id: 'f-9', status: 'changed', change: 0.042, baseline: 'c-1' }));
  const review = new InspectionReview();
  assert.deepEqual(review.falseAlarm('a shadow'), [], 'nothing open: nothing to mark');
  review.select('f-9');
  assert.deepEqual(review.falseAlarm('  a shadow at dusk '), [
    { type: 'finding_update', finding: 'f-9', fields: { status: 'false_alarm', note: 'a shadow at dusk' } },
  ]);
  assert.deepEqual(review.falseAlarm('   '), [
    { type: 'finding_update', finding: 'f-9', fields: { status: 'false_alarm' } },
  ]);
  assert.equal(
    /** @type {any} */ (review.falseAlarm('x'.repeat(1200))[0]).fields.note.length,
    1000,
    "the relay's limit",
  );
  const size = /** @type {[number, number]} */ ([640, 480]);
  const card = cardLayout({
    status: 'changed',
    proposal: false,
    imageAction: 'region',
    operator: true,
    imageSize: size,
  });
  assert.deepEqual(
    card.buttons.filter((b) => b.active).map((b) => b.id),
    ['status:changed', 'image:region', 'card:image'],
  );
  for (const a of card.buttons)
    for (const b of card.buttons)
      if (a !== b)
        assert.ok(a.x + a.w <= b.x || b.x + b.w <= a.x || a.y + a.h <= b.y || b.y + b.h <= a.y, `${a.id} / ${b.id}`);
  const mark = /** @type {import('../src/finding_card_layout.js').CardButton} */ (
    card.buttons.find((b) => b.id === 'status:false_alarm')
  );
  assert.deepEqual(cardHit(card, size, mark.x + mark.w / 2, mark.y + mark.h / 2), { button: 'status:false_alarm' });
});

/** A viewer's card state for a capture of `size`. @param {[number, number]} size */
function viewerState(size) {
  return {
    status: 'changed',
    proposal: false,
    imageAction: /** @type {'region'} */ ('region'),
    operator: false,
    imageSize: size,
  };
}
