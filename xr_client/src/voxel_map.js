// @ts-check
/**
 * The live 3D map as the relay streams it (docs/protocol.md, "Voxel map blocks"), without WebGL: a `voxel_map`
 * message announces a batch, the binary frames after it carry block records, and the model keeps the blocks the
 * client holds. A record replaces the block of its index; one of 0 voxels removes it; `reset` drops everything first.
 * `pack` writes every voxel's centre (scene coordinates) and colour into flat arrays for the view
 * (view/voxel_view.js), which draws them as instances: RGB where the relay sent colours, else the relay's height ramp
 * (blue at 0 m, cyan, green, yellow, red at 3 m and above: relay/cloud/blocks_wire.py `height_colours`).
 * `raycast` walks a ray through the voxels (map frame) to the first one held: what a pointer meets on the map.
 */
import { mapToScene } from './frames.js';

/** A record's first byte (`X` of `XRVB`); a camera frame's is 0 (its big-endian header length is under 16 MiB). */
export const RECORD_FIRST_BYTE = 0x58;
const MAGIC = 'XRVB';
const LAYOUT_VERSION = 1;
const HEADER_BYTES = 28;
const COLOURED = 1;
/** Voxels a block's side. */
export const BLOCK = 16;
/** The heights (m, map frame) the ramp spans, and its colours low to high (0..1), as the relay's. */
export const HEIGHT_RANGE = /** @type {const} */ ([0, 3]);
const RAMP = [
  [0, 0, 1],
  [0, 1, 1],
  [0, 1, 0],
  [1, 1, 0],
  [1, 0, 0],
];

/**
 * A decoded record: the block's index (block coordinates), version, voxel side (m), each voxel's local index
 * (`x * 256 + y * 16 + z`) and, when the relay sent them, its RGB565 colour. Views into the frame's buffer.
 * @typedef {{index: [number, number, number], version: number, voxel: number, local: Uint16Array,
 *   rgb: Uint16Array | null}} VoxelBlock
 */

/** Whether a binary frame holds block records (else it is a camera frame). @param {ArrayBuffer} buffer */
export function isVoxelFrame(buffer) {
  return buffer.byteLength >= HEADER_BYTES && new Uint8Array(buffer, 0, 1)[0] === RECORD_FIRST_BYTE;
}

/**
 * The records of a frame. Little-endian, as every platform's typed arrays are: the arrays are viewed in place.
 * @param {ArrayBuffer} buffer @returns {VoxelBlock[]}
 */
export function decodeBlocks(buffer) {
  const view = new DataView(buffer);
  /** @type {VoxelBlock[]} */
  const blocks = [];
  let offset = 0;
  while (offset < buffer.byteLength) {
    if (buffer.byteLength - offset < HEADER_BYTES) {
      throw new Error(`voxel block record at byte ${offset}: ${buffer.byteLength - offset} bytes, the header is 28`);
    }
    const magic = String.fromCharCode(...new Uint8Array(buffer, offset, 4));
    const layout = view.getUint8(offset + 4);
    if (magic !== MAGIC || layout !== LAYOUT_VERSION) {
      throw new Error(`voxel block record at byte ${offset}: magic ${magic} version ${layout}`);
    }
    const coloured = (view.getUint8(offset + 5) & COLOURED) !== 0;
    const count = view.getUint16(offset + 6, true);
    const start = offset + HEADER_BYTES;
    const end = start + (coloured ? 4 : 2) * count;
    if (end > buffer.byteLength) {
      throw new Error(`voxel block record at byte ${offset}: ${count} voxels need ${end - offset} bytes`);
    }
    blocks.push({
      index: [view.getInt32(offset + 8, true), view.getInt32(offset + 12, true), view.getInt32(offset + 16, true)],
      version: view.getUint32(offset + 20, true),
      voxel: view.getFloat32(offset + 24, true),
      local: new Uint16Array(buffer, start, count),
      rgb: coloured ? new Uint16Array(buffer, start + 2 * count, count) : null,
    });
    offset = end;
  }
  return blocks;
}

/**
 * An RGB565 word as 0..1 channels, each channel's top bits repeated into its low ones (31 -> 1.0), as the relay.
 * @param {number} word @param {Float32Array} out @param {number} at
 */
export function rgb565(word, out, at) {
  const r = (word >> 11) & 31;
  const g = (word >> 5) & 63;
  const b = word & 31;
  out[at] = ((r << 3) | (r >> 2)) / 255;
  out[at + 1] = ((g << 2) | (g >> 4)) / 255;
  out[at + 2] = ((b << 3) | (b >> 2)) / 255;
}

/**
 * The height ramp's colour at `z` (m, map frame). @param {number} z @param {Float32Array} out @param {number} at
 */
export function heightColour(z, out, at) {
  const [low, high] = HEIGHT_RANGE;
  const t = Math.min(1, Math.max(0, (z - low) / (high - low))) * (RAMP.length - 1);
  const i = Math.min(RAMP.length - 2, Math.floor(t));
  const f = t - i;
  for (let c = 0; c < 3; c++) out[at + c] = RAMP[i][c] + (RAMP[i + 1][c] - RAMP[i][c]) * f;
}

/**
 * Where a ray first meets a voxel held: its distance along the ray, the point on the voxel's face, and the face's
 * outward normal (map frame; a unit axis, or the ray reversed when the ray starts inside a voxel).
 * @typedef {{distance: number, point: [number, number, number], normal: [number, number, number]}} VoxelHit
 */

/** Voxels a ray crosses at most (a 20 m ray at 1 cm voxels crosses 6 000): its walk is bounded whatever it is given. */
const MAX_STEPS = 8192;

export class VoxelMapModel {
  /** The blocks held, by index (`"x,y,z"`). @type {Map<string, VoxelBlock>} */
  blocks = new Map();
  /** The map's version the client holds (every frame of the last batch applied). */
  version = 0;
  /** A voxel's side (m). */
  voxel = 0.05;
  /** Frames of the announced batch still to come. */
  expected = 0;
  /** Voxels held. */
  count = 0;
  /** Something changed since the view last packed. */
  changed = false;
  #next = 0;

  /** A `voxel_map` message. @param {import('./protocol.js').VoxelMapMessage} message */
  begin(message) {
    if (message.reset) {
      this.blocks.clear();
      this.count = 0;
    }
    this.voxel = message.voxel;
    this.#next = message.version;
    this.expected = message.frames;
    if (this.expected === 0) this.version = message.version;
    this.changed = true;
  }

  /** A binary frame of records (isVoxelFrame). @param {ArrayBuffer} buffer */
  frame(buffer) {
    for (const block of decodeBlocks(buffer)) {
      const key = block.index.join(',');
      this.count -= this.blocks.get(key)?.local.length ?? 0;
      if (block.local.length === 0) this.blocks.delete(key);
      else {
        this.blocks.set(key, block);
        this.count += block.local.length;
      }
    }
    this.expected = Math.max(0, this.expected - 1);
    if (this.expected === 0) this.version = this.#next;
    this.changed = true;
  }

  /**
   * The first voxel held along a ray (map frame, m), within `far` m: a walk from voxel to voxel (Amanatides and Woo),
   * each a lookup in its block, never a test of every voxel (100 000 boxes, a frame's time on a headset).
   * @param {[number, number, number]} origin @param {[number, number, number]} direction need not be unit
   * @param {number} far @returns {VoxelHit | null}
   */
  raycast(origin, direction, far) {
    const length = Math.hypot(...direction);
    if (this.blocks.size === 0 || !(length > 0) || !origin.every(Number.isFinite)) return null;
    const s = this.voxel;
    const d = direction.map((v) => v / length);
    const cell = origin.map((v) => Math.floor(v / s));
    const step = d.map((v) => (v > 0 ? 1 : v < 0 ? -1 : 0));
    const next = d.map((v, a) => (v === 0 ? Infinity : ((cell[a] + (v > 0 ? 1 : 0)) * s - origin[a]) / v));
    const delta = d.map((v) => (v === 0 ? Infinity : s / Math.abs(v)));
    /** @type {[number, number, number]} */
    let normal = [-d[0], -d[1], -d[2]];
    let t = 0;
    for (let n = 0; n < MAX_STEPS && t <= far; n++) {
      if (this.#holds(cell[0], cell[1], cell[2])) {
        return { distance: t, point: [origin[0] + d[0] * t, origin[1] + d[1] * t, origin[2] + d[2] * t], normal };
      }
      const a = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : next[1] < next[2] ? 1 : 2;
      t = next[a];
      cell[a] += step[a];
      next[a] += delta[a];
      normal = [0, 0, 0];
      normal[a] = -step[a];
    }
    return null;
  }

  /**
   * Each block's voxels as a set of local indices, made when a ray first asks.
   * @type {WeakMap<VoxelBlock, Set<number>>}
   */
  #sets = new WeakMap();

  /** Whether the voxel at cell (i, j, k) is held. @param {number} i @param {number} j @param {number} k */
  #holds(i, j, k) {
    const bx = Math.floor(i / BLOCK);
    const by = Math.floor(j / BLOCK);
    const bz = Math.floor(k / BLOCK);
    const block = this.blocks.get(`${bx},${by},${bz}`);
    if (!block) return false;
    let set = this.#sets.get(block);
    if (!set) this.#sets.set(block, (set = new Set(block.local)));
    return set.has((i - bx * BLOCK) * 256 + (j - by * BLOCK) * 16 + (k - bz * BLOCK));
  }

  /** Whether the announced batch has come whole (the view draws whole batches). */
  get complete() {
    return this.expected === 0;
  }

  /**
   * Every voxel's centre in the scene (glTF Y-up, through `t`) and its colour, at most `capacity` of them.
   * @param {import('./frames.js').MapToScene} t @param {Float32Array} positions 3 a voxel
   * @param {Float32Array} colours 3 a voxel @param {number} capacity @returns {number} voxels written
   */
  pack(t, positions, colours, capacity) {
    let n = 0;
    for (const block of this.blocks.values()) {
      const s = block.voxel;
      const [bx, by, bz] = block.index;
      const { local, rgb } = block;
      for (let i = 0; i < local.length && n < capacity; i++, n++) {
        const word = local[i];
        const x = (bx * BLOCK + (word >> 8) + 0.5) * s;
        const y = (by * BLOCK + ((word >> 4) & 15) + 0.5) * s;
        const z = (bz * BLOCK + (word & 15) + 0.5) * s;
        const [gx, gy, gz] = mapToScene(t, x, y, z);
        positions[3 * n] = gx;
        positions[3 * n + 1] = gy;
        positions[3 * n + 2] = gz;
        if (rgb) rgb565(rgb[i], colours, 3 * n);
        else heightColour(z, colours, 3 * n);
      }
    }
    this.changed = false;
    return n;
  }
}
