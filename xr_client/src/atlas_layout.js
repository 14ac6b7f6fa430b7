// @ts-check
/**
 * Where each robot's label goes in the one texture that holds them all (view/label_atlas.js): cells of a fixed
 * size in rows of a fixed-width atlas, one per robot in the fleet's order, and the texture coordinates of each
 * (v down from the top: the atlas is uploaded without flipY so that a single cell can be uploaded alone).
 * Pure: test/atlas_layout.test.js.
 */

/** Browsers guarantee at least 4096 px textures on a WebGL 2 device (a Quest's is 8192). */
export const ATLAS_MAX = 4096;

/**
 * @typedef {{x: number, y: number, w: number, h: number, u0: number, v0: number, u1: number, v1: number}} Cell
 *   pixels from the atlas's top-left corner, and its texture coordinates (v0 at the cell's top)
 */

export class AtlasLayout {
  /**
   * @param {number} count cells wanted (robots in the fleet)
   * @param {number} cellWidth @param {number} cellHeight pixels
   * @param {number} [maxWidth] the atlas's width at most (pixels)
   */
  constructor(count, cellWidth, cellHeight, maxWidth = 2048) {
    if (cellWidth > maxWidth || cellHeight > ATLAS_MAX)
      throw new Error(`a ${cellWidth}x${cellHeight} cell does not fit a ${maxWidth} px atlas`);
    this.cellWidth = cellWidth;
    this.cellHeight = cellHeight;
    this.columns = Math.max(1, Math.min(Math.max(1, count), Math.floor(maxWidth / cellWidth)));
    const rowsMax = Math.floor(ATLAS_MAX / cellHeight);
    /** Cells the atlas holds: more robots than this get no label (1024 with 256x75 cells in 2048 x 4096). */
    this.capacity = Math.min(count, this.columns * rowsMax);
    this.rows = Math.max(1, Math.ceil(this.capacity / this.columns));
    this.width = this.columns * cellWidth;
    this.height = this.rows * cellHeight;
  }

  /** The i-th cell, or null past the capacity. @param {number} i @returns {Cell | null} */
  cell(i) {
    if (!(i >= 0 && i < this.capacity && Number.isInteger(i))) return null;
    const x = (i % this.columns) * this.cellWidth;
    const y = Math.floor(i / this.columns) * this.cellHeight;
    const w = this.cellWidth;
    const h = this.cellHeight;
    return { x, y, w, h, u0: x / this.width, v0: y / this.height, u1: (x + w) / this.width, v1: (y + h) / this.height };
  }
}
