// @ts-check
/**
 * The one place where ROS coordinates meet glTF/three.js coordinates, mirroring relay/twin/frames.py.
 *
 * ROS (REP 103) is right-handed Z-up; glTF is right-handed Y-up with +Z towards the viewer:
 *
 *     gltf = (x_ros, z_ros, -y_ros)        ros = (x_gltf, -z_gltf, y_gltf)
 *
 * A yaw about ROS +z is a rotation about glTF +y by the same angle (three.js `rotation.y`).
 * `hello.scene.map_to_scene` places the map frame in the scene in ROS conventions: a map point p is at
 * Rz(yaw)·p + (x, y, z) in the scene's ROS frame, then converted to glTF as above.
 */

/**
 * @typedef {import('./protocol.js').Transform2D} MapToScene where the map frame sits in the twin
 * (hello.scene.map_to_scene)
 */

/**
 * @param {number} x @param {number} y @param {number} z
 * @returns {[number, number, number]}
 */
export function rosToGltf(x, y, z) {
  return [x, z, -y];
}

/**
 * @param {number} x @param {number} y @param {number} z
 * @returns {[number, number, number]}
 */
export function gltfToRos(x, y, z) {
  return [x, -z, y];
}

/**
 * A map-frame point (ROS, metres) to scene coordinates (glTF Y-up).
 * @param {MapToScene} t @param {number} x @param {number} y @param {number} [z]
 * @returns {[number, number, number]}
 */
export function mapToScene(t, x, y, z = 0) {
  const c = Math.cos(t.yaw);
  const s = Math.sin(t.yaw);
  return rosToGltf(c * x - s * y + t.x, s * x + c * y + t.y, z + t.z);
}

/**
 * A scene point (glTF Y-up) back to the map frame (ROS): the inverse of `mapToScene`.
 * @param {MapToScene} t @param {number} gx @param {number} gy @param {number} gz
 * @returns {[number, number, number]}
 */
export function sceneToMap(t, gx, gy, gz) {
  const [rx, ry, rz] = gltfToRos(gx, gy, gz);
  const dx = rx - t.x;
  const dy = ry - t.y;
  const c = Math.cos(t.yaw);
  const s = Math.sin(t.yaw);
  return [c * dx + s * dy, -s * dx + c * dy, rz - t.z];
}

/**
 * A map-frame yaw (radians about ROS +z) as a rotation about the scene's +y (three.js `rotation.y`).
 * @param {MapToScene} t @param {number} yaw
 */
export function mapYawToScene(t, yaw) {
  return yaw + t.yaw;
}

/** @param {MapToScene} t @param {number} sceneYaw */
export function sceneYawToMap(t, sceneYaw) {
  return normalizeAngle(sceneYaw - t.yaw);
}

/** An angle wrapped into (-pi, pi]. @param {number} a */
export function normalizeAngle(a) {
  const twoPi = 2 * Math.PI;
  let r = a % twoPi;
  if (r <= -Math.PI) r += twoPi;
  else if (r > Math.PI) r -= twoPi;
  return r;
}

/**
 * `hello.scene.map_to_scene`, defaulting missing fields to the identity.
 * @param {Partial<MapToScene> | null | undefined} value
 * @returns {MapToScene}
 */
export function parseMapToScene(value) {
  return {
    x: Number(value?.x ?? 0),
    y: Number(value?.y ?? 0),
    z: Number(value?.z ?? 0),
    yaw: Number(value?.yaw ?? 0),
  };
}
