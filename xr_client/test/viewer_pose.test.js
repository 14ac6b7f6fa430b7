// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ViewerPacer, VIEWER_PERIOD_MS, poseToScene, viewerMessage } from '../src/viewer_pose.js';
import { AVATAR_STALE_S, AvatarModel } from '../src/avatar_model.js';
import { mapToScene } from '../src/frames.js';

const T = { x: 1.0, y: -2.0, z: 0.0, yaw: Math.PI / 2 };

/** @param {number[]} actual @param {number[]} expected @param {number} eps */
function near(actual, expected, eps) {
  assert.equal(actual.length, expected.length);
  actual.forEach((v, i) => assert.ok(Math.abs(v - expected[i]) <= eps, `${actual} != ${expected}`));
}

test('a viewpoint goes to the map frame, rounded, and comes back into the scene where it was', () => {
  // The operator stands at map (3, 4), eyes 1.6 m up, looking along the map's +x; a hand points along map +y.
  const eye = mapToScene(T, 3, 4, 1.6);
  const along = (/** @type {number} */ x, /** @type {number} */ y) => {
    const [a, b, c] = mapToScene(T, x, y, 0);
    const [o, p, q] = mapToScene(T, 0, 0, 0);
    return /** @type {[number, number, number]} */ ([a - o, b - p, c - q]);
  };
  const hand = mapToScene(T, 3.2, 3.9, 1.1);
  const message = viewerMessage(T, { position: eye, direction: along(2, 0) }, [
    { hand: 'right', position: hand, direction: along(0, 5) },
    { hand: 'right', position: hand, direction: along(0, 1) }, // a second right hand: left out
    { hand: 'left', position: hand, direction: [0, 0, 0] }, // no ray: left out
  ]);
  assert.ok(message);
  assert.deepEqual(message.head, { position: [3, 4, 1.6], look: [1, 0, 0] });
  assert.deepEqual(message.hands, [{ hand: 'right', position: [3.2, 3.9, 1.1], ray: [0, 1, 0] }]);
  const back = poseToScene(T, message.head.position, message.head.look);
  assert.ok(back);
  near(back.position, eye, 1e-9);
  near(back.direction, along(1, 0), 1e-9);
  assert.equal(message.view, undefined, 'what it looks through: not said');
  assert.equal(viewerMessage(T, { position: eye, direction: along(1, 0) }, [], 'top')?.view, 'top');
  assert.equal(viewerMessage(T, { position: eye, direction: [0, 0, 0] }), null, 'no facing: no viewpoint');
  assert.equal(viewerMessage(T, { position: [NaN, 0, 0], direction: [1, 0, 0] }), null);
});

test('the viewpoint is sent 4 times a second at most', () => {
  const pacer = new ViewerPacer();
  const sent = [];
  for (let now = 0; now < 1000; now += 16) if (pacer.due(now)) sent.push(now);
  assert.equal(VIEWER_PERIOD_MS, 250);
  assert.deepEqual(sent, [0, 256, 512, 768]);
});

/** @param {string} client @param {number} stamp @param {number} x @returns {import('../src/protocol.js').AvatarMessage} */
function avatar(client, stamp, x) {
  return {
    identifier: 'avatar',
    client,
    name: client === 'c1' ? 'Ana' : null,
    stamp,
    head: { position: [x, 2, 1.6], look: [0, 1, 0] },
    hands: [{ hand: 'left', position: [x, 2.2, 1.0], ray: [1, 0, 0] }],
  };
}

test("a replay's operators are drawn where they were, named, until the replay moves away from their time", () => {
  const model = new AvatarModel();
  model.apply(avatar('c1', 100.0, 3));
  model.apply(avatar('c2', 100.5, 5));
  const figures = model.figures(T);
  assert.deepEqual(
    figures.map((f) => f.label),
    ['Ana', 'c2'],
  );
  near(figures[0].head.position, mapToScene(T, 3, 2, 1.6), 1e-9);
  assert.equal(figures[0].hands.length, 1);
  near(figures[0].hands[0].position, mapToScene(T, 3, 2.2, 1.0), 1e-9);
  model.apply(avatar('c1', 100.0 + AVATAR_STALE_S, 3.5)); // c1 moves on; c2 sent nothing for over 2 s
  assert.deepEqual([...model.avatars.keys()], ['c1', 'c2'], '1.5 s old: still shown');
  model.at(100.6 + AVATAR_STALE_S);
  assert.deepEqual([...model.avatars.keys()], ['c1'], 'c2 left');
  model.at(90); // a seek back, before anyone's viewpoint
  assert.equal(model.avatars.size, 0);
  model.apply(avatar('c1', 90.1, 1));
  model.clear();
  assert.equal(model.figures(T).length, 0);
});
