// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import {
  gltfToRos,
  mapToScene,
  mapYawToScene,
  normalizeAngle,
  rosToGltf,
  sceneToMap,
  sceneYawToMap,
} from '../src/frames.js';

const pinned = JSON.parse(readFileSync(new URL('./fixtures/frames_points.json', import.meta.url), 'utf8'));

/** @param {number[]} actual @param {number[]} expected */
function near(actual, expected, eps = 1e-9) {
  assert.equal(actual.length, expected.length);
  actual.forEach((v, i) => assert.ok(Math.abs(v - expected[i]) < eps, `${actual} != ${expected}`));
}

test('ROS to glTF is (x, z, -y), pinned with the points relay/twin/frames.py is checked against', () => {
  for (const { ros, gltf } of pinned.ros_to_gltf) {
    near(rosToGltf(ros[0], ros[1], ros[2]), gltf);
    near(gltfToRos(gltf[0], gltf[1], gltf[2]), ros);
  }
});

test('map_to_scene is applied first, in ROS coordinates, then converted', () => {
  for (const { transform, map, gltf } of pinned.map_to_scene) {
    near(mapToScene(transform, map[0], map[1], map[2]), gltf);
    near(sceneToMap(transform, gltf[0], gltf[1], gltf[2]), map);
  }
});

test('a yaw about ROS +z is the same rotation about glTF +y', () => {
  const t = { x: 0, y: 0, z: 0, yaw: 0.3 };
  // The robot's forward (cos yaw, sin yaw, 0) in ROS is (cos, 0, -sin) in glTF: a three.js rotation.y by yaw.
  const yaw = 1.1;
  const sceneYaw = mapYawToScene(t, yaw);
  const forward = rosToGltf(Math.cos(yaw + 0.3), Math.sin(yaw + 0.3), 0);
  near(forward, [Math.cos(sceneYaw), 0, -Math.sin(sceneYaw)]);
  assert.ok(Math.abs(sceneYawToMap(t, sceneYaw) - yaw) < 1e-12);
  assert.ok(Math.abs(normalizeAngle(3 * Math.PI) - Math.PI) < 1e-12);
  assert.ok(Math.abs(normalizeAngle((-3 * Math.PI) / 2) - Math.PI / 2) < 1e-12);
});
