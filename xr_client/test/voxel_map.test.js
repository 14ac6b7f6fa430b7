// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { VoxelMapModel, decodeBlocks, heightColour, isVoxelFrame } from '../src/voxel_map.js';

/** docs/protocol.md's pinned record: block (1, -2, 0) at version 7, 5 cm, voxel (0,0,0) red and (15,1,2) green. */
const PINNED = '585256420101020001000000feffffff0000000007000000cdcc4c3d0000120f00f8e007';
/** The relay's encoding of block (0, 0, 0) at version 3 with voxel (1, 2, 3) and no colour. */
const PLAIN = '585256420100010000000000000000000000000003000000cdcc4c3d2301';

/** @param {string} hex */
function buffer(hex) {
  const bytes = new Uint8Array(hex.length / 2);
  for (let i = 0; i < bytes.length; i++) bytes[i] = parseInt(hex.slice(2 * i, 2 * i + 2), 16);
  return bytes.buffer;
}

/** @param {number} version @param {number} since @param {boolean} reset @param {number} frames */
function header(version, since, reset, frames) {
  return /** @type {import('../src/protocol.js').VoxelMapMessage} */ ({
    identifier: 'voxel_map',
    version,
    since,
    reset,
    voxel: 0.05,
    blocks: frames,
    frames,
  });
}

test('the pinned record decodes as docs/protocol.md says', () => {
  const [block] = decodeBlocks(buffer(PINNED));
  assert.deepEqual(block.index, [1, -2, 0]);
  assert.equal(block.version, 7);
  assert.ok(Math.abs(block.voxel - 0.05) < 1e-7);
  assert.deepEqual([...block.local], [0, 15 * 256 + 1 * 16 + 2]);
  assert.deepEqual([...(block.rgb ?? [])], [0xf800, 0x07e0]);
});

test('records follow one another in a frame; a camera frame is told apart by its first byte', () => {
  const both = new Uint8Array([...new Uint8Array(buffer(PINNED)), ...new Uint8Array(buffer(PLAIN))]).buffer;
  const blocks = decodeBlocks(both);
  assert.equal(blocks.length, 2);
  assert.equal(blocks[1].rgb, null);
  assert.ok(isVoxelFrame(both));
  assert.ok(!isVoxelFrame(new Uint8Array([0, 0, 0, 40, ...new Array(40).fill(32)]).buffer));
});

test('a truncated or foreign record is named, never misread', () => {
  assert.throws(() => decodeBlocks(buffer(PINNED).slice(0, 30)), /2 voxels need 36 bytes/);
  assert.throws(() => decodeBlocks(buffer(PINNED.replace('58525642', '58525643'))), /magic XRVC/);
  assert.throws(() => decodeBlocks(buffer(PINNED).slice(0, 20)), /the header is 28/);
});

test('the model keeps whole batches: reset, replace, remove', () => {
  const model = new VoxelMapModel();
  model.begin(header(7, 0, true, 2));
  model.frame(buffer(PINNED));
  assert.ok(!model.complete);
  assert.equal(model.version, 0);
  model.frame(buffer(PLAIN));
  assert.ok(model.complete);
  assert.equal(model.version, 7);
  assert.equal(model.count, 3);
  // A record of 0 voxels removes its block.
  const removed = new Uint8Array(buffer(PLAIN).slice(0, 28));
  removed[6] = 0;
  model.begin(header(8, 7, false, 1));
  model.frame(removed.buffer);
  assert.equal(model.count, 2);
  assert.deepEqual([...model.blocks.keys()], ['1,-2,0']);
  model.begin(header(9, 0, true, 0));
  assert.equal(model.count, 0);
  assert.equal(model.version, 9);
});

test('pack places voxel centres in the scene and colours them by RGB or height', () => {
  const model = new VoxelMapModel();
  model.begin(header(7, 0, true, 1));
  const both = new Uint8Array([...new Uint8Array(buffer(PINNED)), ...new Uint8Array(buffer(PLAIN))]).buffer;
  model.frame(both);
  const positions = new Float32Array(9);
  const colours = new Float32Array(9);
  const identity = { x: 0, y: 0, z: 0, yaw: 0 };
  assert.equal(model.pack(identity, positions, colours, 3), 3);
  // Voxel (0,0,0) of block (1,-2,0): map (0.825, -1.575, 0.025) -> glTF (x, z, -y).
  const near = (/** @type {number} */ a, /** @type {number} */ b) => assert.ok(Math.abs(a - b) < 1e-5, `${a} != ${b}`);
  [0.825, 0.025, 1.575].forEach((v, i) => near(positions[i], v));
  assert.deepEqual([...colours.slice(0, 6)], [1, 0, 0, 0, 1, 0]);
  // No colour: the height ramp at z = 0.175 m, nearly blue.
  const ramp = new Float32Array(3);
  heightColour(0.175, ramp, 0);
  assert.deepEqual([...colours.slice(6, 9)], [...ramp]);
  assert.ok(ramp[2] === 1 && ramp[1] > 0.2 && ramp[1] < 0.3);
  // Bounded by the capacity given.
  assert.equal(model.pack(identity, positions, colours, 2), 2);
});

test('the height ramp runs blue, cyan, green, yellow, red over 0..3 m', () => {
  const out = new Float32Array(3);
  const at = (/** @type {number} */ z) => (heightColour(z, out, 0), [...out]);
  assert.deepEqual(at(-1), [0, 0, 1]);
  assert.deepEqual(at(0.75), [0, 1, 1]);
  assert.deepEqual(at(1.5), [0, 1, 0]);
  assert.deepEqual(at(2.25), [1, 1, 0]);
  assert.deepEqual(at(5), [1, 0, 0]);
});

test("the menu's options show and hide the 3D map and the twin, on the desktop and in VR alike", async () => {
  const { MenuState } = await import('../src/menu_state.js');
  const m = new MenuState();
  m.setFleet([{ name: 'robot1', hasCamera: true }], 'viewer');
  const find = (/** @type {string} */ id) => m.buttons().find((b) => b.id === id);
  assert.deepEqual(
    [find('opt:map3d'), find('opt:twin')].map((b) => [b?.label, b?.active, b?.enabled]),
    [
      ['3D map', true, true],
      ['Twin', true, true],
    ],
  );
  assert.deepEqual(m.press('opt:twin'), []);
  assert.equal(m.options.twin, false);
  assert.equal(find('opt:twin')?.active, false);
  m.press('opt:map3d');
  assert.equal(m.options.map3d, false);
  assert.equal(m.options.twin, false);
});

/**
 * A frame of one uncoloured record per block, as the relay writes them (relay/cloud/blocks_wire.py).
 * @param {Map<string, number[]>} blocks "bx,by,bz" -> local indices @param {number} voxel
 */
function frameOf(blocks, voxel) {
  const records = [...blocks].map(([key, local]) => {
    const bytes = new ArrayBuffer(28 + 2 * local.length);
    const view = new DataView(bytes);
    [...'XRVB'].forEach((c, i) => view.setUint8(i, c.charCodeAt(0)));
    view.setUint8(4, 1);
    view.setUint16(6, local.length, true);
    key.split(',').forEach((v, i) => view.setInt32(8 + 4 * i, Number(v), true));
    view.setUint32(20, 1, true);
    view.setFloat32(24, voxel, true);
    local.forEach((word, i) => view.setUint16(28 + 2 * i, word, true));
    return new Uint8Array(bytes);
  });
  const out = new Uint8Array(records.reduce((n, r) => n + r.length, 0));
  records.reduce((at, r) => (out.set(r, at), at + r.length), 0);
  return out.buffer;
}

/**
 * A room of 10 cm voxels: a floor layer (z index 0) over x, y in 0..39 and a wall at x index 30, z 1..19.
 * @returns {VoxelMapModel}
 */
function room() {
  /** @type {Map<string, number[]>} */
  const blocks = new Map();
  const put = (/** @type {number} */ i, /** @type {number} */ j, /** @type {number} */ k) => {
    const key = [Math.floor(i / 16), Math.floor(j / 16), Math.floor(k / 16)].join(',');
    blocks.set(key, [...(blocks.get(key) ?? []), (i % 16) * 256 + (j % 16) * 16 + (k % 16)]);
  };
  for (let i = 0; i < 40; i++) for (let j = 0; j < 40; j++) put(i, j, 0);
  for (let j = 0; j < 40; j++) for (let k = 1; k < 20; k++) put(30, j, k);
  const model = new VoxelMapModel();
  model.begin({ ...header(1, 0, true, 1), voxel: 0.1 });
  model.frame(frameOf(blocks, 0.1));
  return model;
}

test('a ray meets the first voxel held: the floor from above, a wall from the side, nothing past its reach', () => {
  const model = room();
  const near = (/** @type {number[]} */ a, /** @type {number[]} */ b) =>
    assert.ok(
      a.every((v, i) => Math.abs(v - b[i]) < 1e-9),
      `${a} != ${b}`,
    );
  // Down from 1.5 m at (1.23, 2.05): the floor layer's top face, 0.1 m up, facing up.
  const down = /** @type {import('../src/voxel_map.js').VoxelHit} */ (model.raycast([1.23, 2.05, 1.5], [0, 0, -2], 20));
  near(down.point, [1.23, 2.05, 0.1]);
  near(down.normal, [0, 0, 1]);
  assert.ok(Math.abs(down.distance - 1.4) < 1e-9);
  // Along +x at 1 m high: the wall's near face at x = 3.0, facing back along -x.
  const side = /** @type {import('../src/voxel_map.js').VoxelHit} */ (model.raycast([0.55, 1.0, 1.0], [1, 0, 0], 20));
  near(side.point, [3.0, 1.0, 1.0]);
  near(side.normal, [-1, 0, 0]);
  // Slanting down towards the wall: whichever comes first along the ray (here the floor, 0.8 m out).
  const slant = /** @type {import('../src/voxel_map.js').VoxelHit} */ (model.raycast([0.55, 1.0, 0.9], [1, 0, -1], 20));
  near(slant.normal, [0, 0, 1]);
  assert.ok(Math.abs(slant.point[0] - 1.35) < 1e-9 && Math.abs(slant.point[2] - 0.1) < 1e-9, `${slant.point}`);
  // Up, away from the map, or short of the wall: nothing.
  assert.equal(model.raycast([1.0, 1.0, 1.0], [0, 0, 1], 20), null);
  assert.equal(model.raycast([0.55, 1.0, 1.0], [1, 0, 0], 2.0), null);
  // From inside a voxel: met at once, facing the ray.
  const inside = /** @type {import('../src/voxel_map.js').VoxelHit} */ (model.raycast([3.05, 1.0, 1.0], [1, 0, 0], 20));
  assert.equal(inside.distance, 0);
  // Negative coordinates (a block below zero), a zero or non-finite ray: handled, never thrown.
  assert.equal(model.raycast([-5, -5, 1], [0, 0, -1], 20), null);
  assert.equal(model.raycast([1, 1, 1], [0, 0, 0], 20), null);
  assert.equal(model.raycast([NaN, 1, 1], [0, 0, -1], 20), null);
  assert.equal(new VoxelMapModel().raycast([1, 1, 1], [0, 0, -1], 20), null);
  // A block below zero in y: the pinned record's voxel (15, 1, 2) of block (1, -2, 0), at 5 cm.
  const pinned = new VoxelMapModel();
  pinned.begin(header(7, 0, true, 1));
  pinned.frame(buffer(PINNED));
  const hit = /** @type {import('../src/voxel_map.js').VoxelHit} */ (pinned.raycast([1.575, -1.525, 1], [0, 0, -1], 5));
  near(hit.point, [1.575, -1.525, 0.15]);
});
