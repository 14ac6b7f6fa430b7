// @ts-check
/**
 * Live H.264 video (docs/protocol.md, "Binary frames", Video): the state machine around one WebCodecs
 * `VideoDecoder`, and the rule that picks a stream's codec. No DOM and no WebCodecs here: the decoder, the support
 * check and the chunk constructor are handed in (`DecoderPlatform`), so that a unit test drives it with a fake
 * (test/video_decoder.test.js) and view/camera_feed.js with the browser's.
 *
 * The relay's packets are Annex B access units (SPS and PPS in front of every keyframe), so the decoder is configured
 * from the first keyframe's `codec` string alone, with no `description`. A decoder can only start at a keyframe:
 * until one arrives (at the start, after a decoder error, after falling behind) packets are skipped, and on an error
 * the relay is asked again (`restart`: the stream command re-sent, to which it answers with a keyframe at once).
 * The relay itself never sends a packet after a gap that is not a keyframe (its video lane drops up to the next one).
 *
 * Decoded frames are held one at a time: a frame not yet taken (`take`) when the next one is decoded is closed and
 * counted as dropped, so a page that draws at 3 frames a second (software WebGL) shows the newest picture and never
 * holds a decoder's pool of frames (a hardware decoder stalls when its few output buffers are not returned).
 */

/**
 * Packets waiting in the decoder beyond which it is behind (1 s at 30 fps): it starts over at the next keyframe. A
 * software decoder on this 2-core machine keeps 0-2 queued at 480x480 15 fps; a stuck one would grow without end.
 */
export const MAX_DECODE_QUEUE = 30;
/** Packets kept while the browser says whether it decodes the codec (a promise: a few ms; 1 s at 30 fps at most). */
export const MAX_PENDING = 30;
/**
 * Decoder errors in a row, with no picture between them, after which the stream is not decodable here: each one
 * costs a keyframe from the relay (about a second of nothing on screen), so a decoder that fails every keyframe it
 * is given falls back to JPEG instead of asking forever.
 */
export const MAX_FAILURES = 3;

/**
 * @typedef {{timestamp: number, close(): void}} FrameLike a decoded picture (a VideoFrame)
 * @typedef {{configure(config: {codec: string, optimizeForLatency: boolean}): void, decode(chunk: any): void,
 *   close(): void, decodeQueueSize: number, state: string}} DecoderLike a VideoDecoder
 * @typedef {{create(init: {output: (frame: FrameLike) => void, error: (error: Error) => void}): DecoderLike,
 *   supported(config: {codec: string, optimizeForLatency: boolean}): Promise<boolean>,
 *   chunk(init: {type: 'key' | 'delta', timestamp: number, data: Uint8Array}): any}} DecoderPlatform
 * @typedef {import('./camera_frame.js').FrameHeader} FrameHeader
 * @typedef {'idle' | 'checking' | 'waiting' | 'decoding' | 'unsupported'} DecoderPhase
 */

/**
 * The codec to ask a camera's stream in: H.264 when the relay offers it for that camera, the browser has a
 * `VideoDecoder`, nobody forced JPEG (`?video=jpeg`) and the camera's video did not turn out undecodable here.
 * @param {{identifier: string, codecs?: string[]} | null} camera
 * @param {{hasDecoder: boolean, forced: string | null, refused: ReadonlySet<string>}} here
 * @returns {'h264' | 'jpeg'}
 */
export function streamCodec(camera, here) {
  if (!camera || !here.hasDecoder || here.forced === 'jpeg' || here.refused.has(camera.identifier)) return 'jpeg';
  return (camera.codecs ?? []).includes('h264') ? 'h264' : 'jpeg';
}

export class H264Decoder {
  /**
   * @param {DecoderPlatform} platform
   * @param {{restart: (why: string) => void, unsupported: (codec: string) => void,
   *   decoded?: (header: FrameHeader) => void}} host `restart`: ask the relay for the stream again (a keyframe
   *   comes first); `unsupported`: this browser cannot decode the stream's codec; `decoded`: a picture came out of
   *   the decoder (its packet's header)
   */
  constructor(platform, host) {
    this.platform = platform;
    this.host = host;
    /** @type {DecoderPhase} */
    this.phase = 'idle';
    /** The camera whose packets are decoded; others are ignored. */
    this.identifier = '';
    /** @type {DecoderLike | null} */
    this.decoder = null;
    /** The codec string the decoder is configured with. */
    this.codec = '';
    /** Bumped whenever the decoder or the stream changes: outputs and answers of an older one are discarded. */
    this.generation = 0;
    /** @type {{header: FrameHeader, payload: Uint8Array}[]} packets that came while the support check ran */
    this.pending = [];
    /** Whether the browser decodes a codec string: asked once. */
    this.support = new CodecSupport(platform);
    /** @type {Map<number, FrameHeader>} header of each packet in the decoder, by its chunk timestamp (seq) */
    this.headers = new Map();
    /** @type {{frame: FrameLike, header: FrameHeader} | null} the newest decoded frame, until taken */
    this.held = null;
    this.lastSeq = 0;
    /** The next packet fed is the first since decoding (re)started. */
    this.startOnKey = false;
    /** Counts for the state snapshot and the tests. */
    this.counts = {
      packets: 0,
      fed: 0,
      keyframes: 0,
      skipped: 0,
      decoded: 0,
      dropped: 0,
      errors: 0,
      restarts: 0,
      /** Decoding (re)started this many times, and this many times on a keyframe (always, by construction). */
      starts: 0,
      startsOnKey: 0,
      /** Packets that came after a gap in `seq` (packets the relay dropped), and how many of them were keyframes. */
      gaps: 0,
      gapKeyframes: 0,
    };
    this.lastError = '';
    /** Decoder errors since the last decoded picture. */
    this.failures = 0;
  }

  /** Decode this camera's stream from its next keyframe (a new stream or a new camera). @param {string} identifier */
  start(identifier) {
    this.#discard();
    if (identifier !== this.identifier) this.#closeHeld(); // another camera's picture
    this.identifier = identifier;
    this.phase = 'waiting';
    this.lastSeq = 0;
  }

  /** No stream: the decoder is closed, the frame not taken too. */
  stop() {
    this.#discard();
    this.#closeHeld();
    this.identifier = '';
    this.phase = 'idle';
  }

  /** One H.264 packet of the relay. @param {FrameHeader} header @param {Uint8Array} payload */
  push(header, payload) {
    if (header.identifier !== this.identifier || this.phase === 'idle' || this.phase === 'unsupported') return;
    this.counts.packets++;
    const keyframe = header.keyframe === true;
    // seq counts every frame of the camera (also JPEG frames and snapshots for others), so a jump is a gap only
    // where nobody else watches; it is counted, not acted on: the relay never sends a delta after a real gap.
    if (this.lastSeq && header.seq > this.lastSeq + 1) {
      this.counts.gaps++;
      if (keyframe) this.counts.gapKeyframes++;
    }
    this.lastSeq = header.seq;
    if (this.phase === 'checking') {
      if (this.pending.length < MAX_PENDING) this.pending.push({ header, payload });
      else this.counts.skipped++;
      return;
    }
    const codec = header.codec ?? '';
    if (this.phase === 'waiting' || codec !== this.codec) {
      if (!keyframe) {
        this.counts.skipped++;
        return;
      }
      if (codec !== this.codec || this.decoder === null) {
        this.#check(codec, { header, payload });
        return;
      }
      this.#begin();
    }
    this.#feed(header, payload);
  }

  /** The newest decoded frame and its packet's header, handed on (the caller closes it), or null. */
  take() {
    const held = this.held;
    this.held = null;
    return held;
  }

  /**
   * Is the browser able to decode `codec`? Asked once per codec string; packets wait meanwhile.
   * @param {string} codec @param {{header: FrameHeader, payload: Uint8Array}} first
   */
  #check(codec, first) {
    this.#closeDecoder();
    this.pending = [first];
    const known = this.support.known(codec);
    if (known !== undefined) {
      this.#checked(codec, known);
      return;
    }
    this.phase = 'checking';
    const generation = this.generation;
    this.support.ask(codec).then((ok) => {
      if (generation === this.generation && this.phase === 'checking') this.#checked(codec, ok);
    });
  }

  /** @param {string} codec @param {boolean} ok */
  #checked(codec, ok) {
    const pending = this.pending;
    this.pending = [];
    if (!ok) {
      this.phase = 'unsupported';
      this.host.unsupported(codec);
      return;
    }
    const generation = ++this.generation;
    const decoder = this.platform.create({
      output: (frame) => this.#output(frame, generation),
      error: (error) => this.#error(error, generation),
    });
    decoder.configure({ codec, optimizeForLatency: true });
    this.decoder = decoder;
    this.codec = codec;
    this.#begin();
    // The first is the keyframe that started the check; the rest came meanwhile, in order.
    for (const { header, payload } of pending) this.#feed(header, payload);
  }

  #begin() {
    this.phase = 'decoding';
    this.counts.starts++;
    this.startOnKey = true;
  }

  /** @param {FrameHeader} header @param {Uint8Array} payload */
  #feed(header, payload) {
    const decoder = this.decoder;
    if (decoder === null || this.phase !== 'decoding') return;
    if (decoder.decodeQueueSize > MAX_DECODE_QUEUE) {
      // The decoder does not keep up: what it has queued is older than a second. Start over at a keyframe.
      this.#recover('behind');
      this.counts.skipped++;
      return;
    }
    const keyframe = header.keyframe === true;
    if (this.startOnKey) {
      if (keyframe) this.counts.startsOnKey++;
      this.startOnKey = false;
    }
    // The chunk's timestamp is the packet's seq: unique per camera, and the output frame carries it back, so
    // the frame finds its header (lens, size, seq) whatever the decoder's latency.
    this.headers.set(header.seq, header);
    try {
      decoder.decode(this.platform.chunk({ type: keyframe ? 'key' : 'delta', timestamp: header.seq, data: payload }));
    } catch (error) {
      // decode() throws synchronously on a closed decoder or a delta where a key is required.
      this.#error(/** @type {Error} */ (error), this.generation);
      return;
    }
    this.counts.fed++;
    if (keyframe) this.counts.keyframes++;
  }

  /** @param {FrameLike} frame @param {number} generation */
  #output(frame, generation) {
    const header = this.headers.get(frame.timestamp);
    this.headers.delete(frame.timestamp);
    if (generation !== this.generation || header === undefined) {
      frame.close(); // a decoder replaced, or a stream stopped, while this frame decoded
      return;
    }
    this.counts.decoded++;
    this.failures = 0;
    this.host.decoded?.(header);
    if (this.held) {
      this.held.frame.close(); // never drawn: the page draws less often than frames come
      this.counts.dropped++;
    }
    this.held = { frame, header };
  }

  /** @param {Error} error @param {number} generation */
  #error(error, generation) {
    if (generation !== this.generation) return;
    this.counts.errors++;
    this.lastError = String(error?.message ?? error);
    if (++this.failures >= MAX_FAILURES) {
      const codec = this.codec;
      this.#closeDecoder();
      this.phase = 'unsupported';
      this.host.unsupported(`${codec} (${this.failures} decoder errors in a row: ${this.lastError})`);
      return;
    }
    this.#recover('decoder error');
  }

  /** Drop the decoder, wait for a keyframe and ask the relay for one. @param {string} why */
  #recover(why) {
    this.#closeDecoder();
    this.phase = 'waiting';
    this.counts.restarts++;
    this.host.restart(why);
  }

  #closeDecoder() {
    this.generation++;
    const decoder = this.decoder;
    this.decoder = null;
    this.codec = '';
    this.headers.clear();
    if (decoder && decoder.state !== 'closed') decoder.close(); // an errored decoder is closed already
  }

  #discard() {
    this.#closeDecoder();
    this.pending = [];
  }

  #closeHeld() {
    this.held?.frame.close();
    this.held = null;
  }

  dispose() {
    this.stop();
  }
}

/** The browser's answer per codec string (isConfigSupported), asked once and remembered. */
class CodecSupport {
  /** @param {DecoderPlatform} platform */
  constructor(platform) {
    this.platform = platform;
    /** @type {Map<string, boolean>} */
    this.answers = new Map();
  }

  /** The answer, if the browser was asked already. @param {string} codec */
  known(codec) {
    return this.answers.get(codec);
  }

  /** Ask the browser (no codec string: not decodable). @param {string} codec @returns {Promise<boolean>} */
  ask(codec) {
    const answer = codec ? this.platform.supported({ codec, optimizeForLatency: true }) : Promise.resolve(false);
    return answer
      .then(
        (ok) => ok,
        () => false, // a malformed codec string rejects (TypeError): not decodable either
      )
      .then((ok) => {
        this.answers.set(codec, ok);
        return ok;
      });
  }
}
