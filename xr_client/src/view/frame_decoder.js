// @ts-check
/**
 * Camera frames off the render path: parse the header, decode the JPEG with createImageBitmap (the
 * browser decodes it on another thread), flipped with imageOrientation 'flipY' (three.js ignores
 * texture.flipY for ImageBitmaps) and resized to the screen's fixed texture size, so that every upload
 * reuses one texture. One decode in flight, newest wins. (H.264 frames take view/camera_feed.js's other path.)
 */
import { LatestOnly, parseFrame } from '../camera_frame.js';

/** @typedef {{header: import('../camera_frame.js').FrameHeader, payload: Uint8Array}} ParsedFrame */

export class FrameDecoder {
  /**
   * @param {() => {width: number, height: number}} size the texture size to decode to
   * @param {(bitmap: ImageBitmap, header: import('../camera_frame.js').FrameHeader) => void} onFrame
   */
  constructor(size, onFrame) {
    this.size = size;
    this.onFrame = onFrame;
    /** Frames with an identifier other than this one are ignored (not the selected robot's camera). */
    this.accept = '';
    this.generation = 0;
    this.decoded = 0;
    this.received = 0;
    /** @type {LatestOnly<{frame: ParsedFrame, generation: number}>} */
    this.queue = new LatestOnly((item) => this.#decode(item));
  }

  /**
   * Only frames of this camera identifier are shown; a change discards decodes in flight. @param {string} identifier
   */
  setAccepted(identifier) {
    if (identifier !== this.accept) {
      this.accept = identifier;
      this.generation++;
    }
  }

  /** @param {ArrayBuffer} buffer */
  push(buffer) {
    this.pushFrame(parseFrame(buffer));
  }

  /** A frame whose header was read already. @param {ParsedFrame} frame */
  pushFrame(frame) {
    this.received++;
    this.queue.submit({ frame, generation: this.generation });
  }

  /** @param {{frame: ParsedFrame, generation: number}} item */
  async #decode({ frame, generation }) {
    const { header, payload } = frame;
    if (header.identifier !== this.accept || generation !== this.generation) return;
    if (header.encoding !== 'jpeg' && header.encoding !== 'png')
      throw new Error(`unsupported frame encoding ${header.encoding}`);
    const { width, height } = this.size();
    const blob = new Blob([/** @type {Uint8Array<ArrayBuffer>} */ (payload)], { type: `image/${header.encoding}` });
    const bitmap = await createImageBitmap(blob, {
      imageOrientation: 'flipY',
      resizeWidth: width,
      resizeHeight: height,
      resizeQuality: 'medium',
      premultiplyAlpha: 'none',
      colorSpaceConversion: 'none',
    });
    if (generation !== this.generation || this.disposed) {
      bitmap.close(); // the operator switched robot while this one decoded
      return;
    }
    this.decoded++;
    this.onFrame(bitmap, header);
  }

  dispose() {
    this.disposed = true;
    this.generation++;
  }
}
