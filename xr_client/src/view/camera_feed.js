// @ts-check
/**
 * The selected robot's camera on the Robot POV screen: which codec a live stream is asked in, and where each
 * binary frame goes. JPEG pictures (snapshots, and streams where video is not possible) go to FrameDecoder
 * (createImageBitmap); H.264 packets to H264Decoder (video_decoder.js) around the browser's WebCodecs
 * `VideoDecoder`, whose newest picture the hemisphere pulls when it is drawn.
 *
 * Video is asked for when the relay offers it for the camera (`hello`'s `codecs`), the browser has `VideoDecoder`
 * and the address does not say `?video=jpeg`. It falls back to JPEG for that camera, said once on the page, when
 * `VideoDecoder.isConfigSupported` refuses the stream's codec string (known only from its first keyframe) or the
 * relay refuses the request; a decoder error asks the relay again (its answer starts with a keyframe).
 */
import { parseFrame } from '../camera_frame.js';
import { H264Decoder, streamCodec } from '../video_decoder.js';
import { PictureTimes } from '../picture_times.js';
import { parseIdentifier } from '../protocol.js';
import { FrameDecoder } from './frame_decoder.js';

/** @typedef {import('../protocol.js').CameraDescription} CameraDescription */

/** WebCodecs as H264Decoder uses it. @returns {import('../video_decoder.js').DecoderPlatform} */
function webCodecs() {
  return {
    create: (init) => /** @type {any} */ (new VideoDecoder(/** @type {any} */ (init))),
    supported: async (config) => (await VideoDecoder.isConfigSupported(config)).supported === true,
    chunk: (init) => new EncodedVideoChunk(init),
  };
}

export class CameraFeed {
  /**
   * @param {{hemisphere: import('./hemisphere_screen.js').HemisphereScreen,
   *   sender: import('../command_sender.js').CommandSender, say: (text: string) => void,
   *   params: URLSearchParams, latency: import('../latency.js').Latency | null}} host `say`: a line for the operator
   *   (the fallback, once); `latency`: told when each picture became drawable
   */
  constructor(host) {
    this.host = host;
    const { hemisphere, sender } = host;
    /** When each picture was decoded, beside its publisher's stamp (both paths): what latency is measured on. */
    this.times = new PictureTimes();
    /** Decoders of cameras shown elsewhere (also). @type {FrameDecoder[]} */
    this.others = [];
    this.jpeg = new FrameDecoder(
      () => ({ width: hemisphere.width, height: hemisphere.height }),
      (bitmap, header) => {
        this.#decoded(header);
        hemisphere.show(bitmap, header);
      },
    );
    this.hasDecoder = typeof VideoDecoder !== 'undefined' && typeof EncodedVideoChunk !== 'undefined';
    /** `?video=jpeg`: never ask for video (a browser whose decoder misbehaves, a comparison). */
    this.forced = host.params.get('video');
    /**
     * Cameras whose video turned out undecodable here, or that the relay would not stream as video. @type {Set<string>}
     */
    this.refused = new Set();
    /** Why the page shows JPEG where it could have shown video, once said ('' when it has not had to). */
    this.fallback = '';
    /**
     * @type {{robot: string, camera: CameraDescription, fps: number, codec: 'jpeg' | 'h264', id: string | null} | null}
     * the live stream asked for
     */
    this.request = null;
    this.video = new H264Decoder(this.hasDecoder ? webCodecs() : unavailable(), {
      restart: () => this.#again(),
      unsupported: (why) =>
        this.#fallBack(`video decoding unavailable: JPEG frames (this browser cannot decode ${why})`),
      decoded: (header) => this.#decoded(header),
    });
    // The decoder hands out what the browser's VideoDecoder gave it: VideoFrames.
    hemisphere.pull = () =>
      /** @type {{frame: VideoFrame, header: import('../camera_frame.js').FrameHeader} | null} */ (this.video.take());
    sender.onVideoRefused = (error) => {
      const r = this.request;
      const ours =
        error.id !== null
          ? String(error.id) === r?.id
          : Boolean(r && error.message.startsWith(`${r.camera.identifier}:`));
      if (ours) this.#fallBack(`video decoding unavailable: JPEG frames (${error.message})`);
    };
  }

  /** The camera identifier whose frames are shown. */
  get accept() {
    return this.jpeg.accept;
  }

  /**
   * Show only this camera's frames (the selected robot's); another camera's decoding stops. @param {string} identifier
   */
  setAccepted(identifier) {
    this.jpeg.setAccepted(identifier);
    if (this.video.identifier && this.video.identifier !== identifier) this.video.stop();
  }

  /**
   * Start (fps > 0) or stop a robot's live stream, as video when this page and the relay can.
   * @param {string} robot @param {CameraDescription} camera @param {number} fps
   */
  stream(robot, camera, fps) {
    if (fps <= 0) {
      this.video.stop();
      this.request = null;
      return this.host.sender.stream(robot, camera.name, 0);
    }
    const codec = streamCodec(camera, { hasDecoder: this.hasDecoder, forced: this.forced, refused: this.refused });
    const id = this.host.sender.stream(robot, camera.name, fps, codec);
    this.request = { robot, camera, fps, codec, id };
    if (codec === 'h264') this.video.start(camera.identifier);
    else this.video.stop();
    return id;
  }

  /**
   * Another camera shown elsewhere than the POV screen (the gripper's, view/gripper_camera.js): the frames of the
   * camera it accepts go to it. @param {FrameDecoder} decoder
   */
  also(decoder) {
    this.others.push(decoder);
  }

  /** A binary frame from the relay. @param {ArrayBuffer} buffer */
  push(buffer) {
    let frame;
    try {
      frame = parseFrame(buffer);
    } catch (error) {
      console.warn('camera frame dropped:', error);
      return;
    }
    const other = this.others.find((d) => d.accept !== '' && d.accept === frame.header.identifier);
    if (other) other.pushFrame(frame);
    else if (frame.header.encoding === 'h264') this.video.push(frame.header, frame.payload);
    else this.jpeg.pushFrame(frame);
  }

  /** The stream again, same camera, rate and codec: the relay answers with a keyframe first. */
  #again() {
    const r = this.request;
    if (r && r.codec === 'h264') r.id = this.host.sender.stream(r.robot, r.camera.name, r.fps, 'h264');
  }

  /** This camera's video cannot be shown here: JPEG from now on, said once. @param {string} why */
  #fallBack(why) {
    const r = this.request;
    if (!r || r.codec !== 'h264') return;
    this.refused.add(r.camera.identifier);
    if (!this.fallback) this.host.say(why);
    this.fallback = why;
    this.stream(r.robot, r.camera, r.fps);
  }

  /** What the state snapshot shows of the video path (`window.__xrRelay.state.video`). */
  state() {
    const v = this.video;
    return {
      codec: this.request?.codec ?? null,
      camera: v.identifier || null,
      phase: v.phase,
      codecString: v.codec || null,
      available: this.hasDecoder && this.forced !== 'jpeg',
      fallback: this.fallback || null,
      lastError: v.lastError || null,
      ...v.counts,
    };
  }

  /** A picture became drawable now: when, beside its stamp (the benchmark's record, the operator's figure). */
  #decoded(/** @type {import('../camera_frame.js').FrameHeader} */ header) {
    const at = performance.now();
    this.times.record(header.stamp, at);
    const robot = parseIdentifier(header.identifier).robot;
    if (robot !== null) this.host.latency?.picture(robot, header.stamp, at);
  }

  dispose() {
    this.jpeg.dispose();
    this.video.dispose();
    this.host.hemisphere.pull = null;
  }
}

/**
 * A browser without WebCodecs: never asked for video (streamCodec), so never called.
 * @returns {import('../video_decoder.js').DecoderPlatform}
 */
function unavailable() {
  const none = () => {
    throw new Error('no VideoDecoder in this browser');
  };
  return { create: none, supported: async () => false, chunk: none };
}
