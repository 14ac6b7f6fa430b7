// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { SPARK_BOX, labelY, polyline, sparkline } from '../src/sparkline.js';

const BOX = { width: 100, height: 50, pad: 5 };

test('rounds run left to right over their span, values bottom to top over a range that holds the threshold', () => {
  // 200, 280, 360 ppm against 400: the range 200-400 widened by 10 % of it, 180-420; inside 90 x 40.
  const line = sparkline(
    [
      [1000, 200],
      [1060, 280],
      [1120, 360],
    ],
    400,
    BOX,
  );
  assert.equal(line.low, 180);
  assert.equal(line.high, 420);
  assert.deepEqual(
    line.points.map((p) => [p.x, p.y]),
    [
      [5, 5 + (220 / 240) * 40],
      [50, 5 + (140 / 240) * 40],
      [95, 5 + (60 / 240) * 40],
    ],
  );
  assert.equal(line.limit, 5 + (20 / 240) * 40); // the threshold, near the top: the line heads for it
  assert.equal(polyline(line.points), '5,41.7 50,28.3 95,15');
});

test('a threshold below every reading is still in view; the rounds keep their spacing in time', () => {
  const line = sparkline(
    [
      [0, 20.9],
      [60, 20.5],
      [180, 20.1],
    ],
    19.5,
    BOX,
  );
  assert.ok(line.limit !== null && line.limit > line.points[2].y && line.limit < BOX.height - BOX.pad + 0.001);
  assert.deepEqual(
    line.points.map((p) => p.x),
    [5, 35, 95],
  );
});

test('one reading sits in the middle; a flat series and no threshold get a band; nothing draws nothing', () => {
  const one = sparkline([[5, 300]], null, BOX);
  assert.deepEqual([one.points[0].x, one.points[0].y, one.limit], [50, 25, null]);
  assert.deepEqual([one.low, one.high], [285, 315]); // 5 % of the value each way
  const zero = sparkline(
    [
      [0, 0],
      [1, 0],
    ],
    null,
    BOX,
  );
  assert.deepEqual([zero.low, zero.high], [-1, 1]);
  assert.deepEqual(sparkline([], null), { points: [], limit: null, low: 0, high: 0 });
  assert.equal(sparkline([], 400, SPARK_BOX).limit, SPARK_BOX.height / 2);
});

test("the threshold's label stays in the box: under a line in the upper half, above one in the lower", () => {
  assert.equal(labelY(6), 15);
  assert.equal(labelY(30), 28);
});
