// @ts-check
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { PictureTimes } from '../src/picture_times.js';
import { H264Decoder, MAX_DECODE_QUEUE, MAX_FAILURES, streamCodec } from '../src/video_decoder.js';

const CAMERA = 'robot1/camera/front';

/** A VideoFrame stand-in that knows whether it was closed. */
class FakeFrame {
  /** @param {number} timestamp */
  constructor(timestamp) {
    this.timestamp = timestamp;
    this.closed = false;
  }
  close() {
    assert.ok(!this.closed, 'a frame closed twice');
    this.closed = true;
  }
}

/** WebCodecs as a test drives it: decoders that output a frame per chunk when told to (`flush`). */
function fakePlatform({ supported = true } = {}) {
  /** @type {any[]} */
  const decoders = [];
  /** @type {FakeFrame[]} */
  const frames = [];
  const platform = {
    checks: 0,
    /** @param {{output: (frame: any) => void, error: (error: Error) => void}} init */
    create(init) {
      const decoder = {
        init,
        state: 'unconfigured',
        /** @type {any[]} */
        queue: [],
        /** @type {any[]} */
        chunks: [],
        get decodeQueueSize() {
          return this.queue.length;
        },
        /** @param {{codec: string}} config */
        configure(config) {
          this.config = config;
          this.state = 'configured';
        },
        /** @param {any} chunk */
        decode(chunk) {
          if (this.state !== 'configured') throw new Error('decode on a closed decoder');
          this.queue.push(chunk);
          this.chunks.push(chunk);
        },
        close() {
          this.state = 'closed';
        },
        /** Decode what is queued: a frame per chunk. */
        flush() {
          for (const chunk of this.queue.splice(0)) {
            const frame = new FakeFrame(chunk.timestamp);
            frames.push(frame);
            this.init.output(frame);
          }
        },
        /** The decoder fails (a corrupt packet): WebCodecs closes it and calls error. */
        fail() {
          this.state = 'closed';
          this.init.error(new Error('Decoding error.'));
        },
      };
      decoders.push(decoder);
      return decoder;
    },
    /** @param {{codec: string}} config */
    supported(config) {
      platform.checks++;
      return Promise.resolve(supported && config.codec.startsWith('avc1.'));
    },
    /** @param {{type: string, timestamp: number, data: Uint8Array}} init */
    chunk(init) {
      return { ...init };
    },
  };
  return { platform, decoders, frames };
}

function host() {
  return {
    /** @type {string[]} */
    restarts: [],
    /** @type {string[]} */
    unsupported: [],
    /** @param {string} why */
    restart(why) {
      this.restarts.push(why);
    },
    /** @param {string} codec */
    unsupportedCodec(codec) {
      this.unsupported.push(codec);
    },
  };
}

/** The decoder's host, recording what it asked. @param {ReturnType<typeof host>} h */
function wire(h) {
  return {
    restart: (/** @type {string} */ why) => h.restart(why),
    unsupported: (/** @type {string} */ c) => h.unsupportedCodec(c),
  };
}

let seq = 0;
/** A packet's header and payload. @param {boolean} keyframe @param {{codec?: string, identifier?: string, seq?: number}} [o] */
function packet(keyframe, o = {}) {
  seq = o.seq ?? seq + 1;
  /** @type {import('../src/camera_frame.js').FrameHeader} */
  const header = {
    identifier: o.identifier ?? CAMERA,
    seq,
    stamp: seq / 15,
    encoding: 'h264',
    width: 480,
    height: 480,
    lens: { model: 'equidistant', fov: 180 },
    request_id: null,
    keyframe,
    codec: o.codec ?? 'avc1.42C01E',
  };
  return /** @type {[typeof header, Uint8Array]} */ ([header, new Uint8Array([0, 0, 0, 1, keyframe ? 0x65 : 0x41])]);
}

const tick = () => new Promise((resolve) => setTimeout(resolve, 0));

test('decoding starts at the first keyframe: deltas before it are skipped, the codec is checked once', async () => {
  const { platform, decoders } = fakePlatform();
  const h = host();
  const d = new H264Decoder(platform, wire(h));
  d.start(CAMERA);
  d.push(...packet(false));
  d.push(...packet(false));
  assert.equal(decoders.length, 0);
  d.push(...packet(true));
  d.push(...packet(false)); // comes while the browser says whether it decodes avc1.42C01E
  assert.equal(d.phase, 'checking');
  await tick();
  assert.equal(d.phase, 'decoding');
  assert.equal(decoders.length, 1);
  assert.deepEqual(decoders[0].config, { codec: 'avc1.42C01E', optimizeForLatency: true });
  assert.deepEqual(
    decoders[0].chunks.map((/** @type {any} */ c) => c.type),
    ['key', 'delta'],
    'the key first, then the one that waited',
  );
  assert.equal(d.counts.skipped, 2);
  assert.equal(d.counts.startsOnKey, 1);
  assert.equal(d.counts.starts, 1);
  assert.equal(platform.checks, 1);
  assert.deepEqual(h.restarts, []);
});

test('at most one frame is held: an untaken frame is closed when the next arrives, and counted dropped', async () => {
  const { platform, decoders, frames } = fakePlatform();
  const d = new H264Decoder(platform, wire(host()));
  d.start(CAMERA);
  d.push(...packet(true));
  await tick();
  d.push(...packet(false));
  d.push(...packet(false));
  decoders[0].flush();
  assert.equal(frames.length, 3);
  assert.equal(d.counts.decoded, 3);
  assert.equal(d.counts.dropped, 2);
  assert.deepEqual(
    frames.map((f) => f.closed),
    [true, true, false],
  );
  const taken = d.take();
  assert.ok(
    taken && taken.frame === frames[2] && taken.header.seq === frames[2].timestamp,
    'the newest, with its own header',
  );
  assert.equal(d.take(), null, 'handed on once');
  d.push(...packet(false));
  decoders[0].flush();
  d.stop();
  assert.ok(frames[3].closed, 'stopping closes the frame nobody took');
  assert.ok(!frames[2].closed, 'the taken one is the taker’s to close');
});

test('a decoder error: the relay is asked again, and decoding resumes at the next keyframe with a new decoder', async () => {
  const { platform, decoders, frames } = fakePlatform();
  const h = host();
  const d = new H264Decoder(platform, wire(h));
  d.start(CAMERA);
  d.push(...packet(true));
  await tick();
  d.push(...packet(false));
  decoders[0].fail();
  assert.equal(d.counts.errors, 1);
  assert.deepEqual(h.restarts, ['decoder error']);
  assert.equal(d.phase, 'waiting');
  d.push(...packet(false));
  d.push(...packet(false));
  assert.equal(decoders.length, 1, 'no decoder fed deltas after an error');
  d.push(...packet(true));
  assert.equal(decoders.length, 2, 'the support answer is remembered: the keyframe goes in at once');
  assert.equal(platform.checks, 1);
  assert.deepEqual(
    decoders[1].chunks.map((/** @type {any} */ c) => c.type),
    ['key'],
  );
  decoders[1].flush();
  assert.equal(d.counts.decoded, 1);
  assert.equal(d.counts.starts, 2);
  assert.equal(d.counts.startsOnKey, 2);
  // A late output of the failed decoder is closed, not shown.
  const late = new FakeFrame(1);
  decoders[0].init.output(late);
  assert.ok(late.closed);
  assert.equal(d.counts.decoded, 1);
  assert.equal(frames.length, 1);
});

test('a decoder that falls behind starts over at a keyframe and asks the relay for one', async () => {
  const { platform, decoders } = fakePlatform();
  const h = host();
  const d = new H264Decoder(platform, wire(h));
  d.start(CAMERA);
  d.push(...packet(true));
  await tick();
  for (let i = 0; i < MAX_DECODE_QUEUE; i++) d.push(...packet(false)); // the key and these: one more than the limit
  assert.deepEqual(h.restarts, []);
  d.push(...packet(false));
  assert.deepEqual(h.restarts, ['behind']);
  assert.equal(decoders[0].state, 'closed');
  d.push(...packet(true));
  assert.equal(d.phase, 'decoding');
  assert.equal(decoders.length, 2);
});

test('a codec the browser cannot decode: said once, and nothing more is fed', async () => {
  const { platform, decoders } = fakePlatform({ supported: false });
  const h = host();
  const d = new H264Decoder(platform, wire(h));
  d.start(CAMERA);
  d.push(...packet(true));
  d.push(...packet(false));
  await tick();
  assert.deepEqual(h.unsupported, ['avc1.42C01E']);
  assert.equal(d.phase, 'unsupported');
  d.push(...packet(true));
  await tick();
  assert.deepEqual(h.unsupported, ['avc1.42C01E']);
  assert.equal(decoders.length, 0);
});

test('a keyframe with another codec string (a new size or level) gets a new decoder', async () => {
  const { platform, decoders } = fakePlatform();
  const d = new H264Decoder(platform, wire(host()));
  d.start(CAMERA);
  d.push(...packet(true));
  await tick();
  d.push(...packet(false, { codec: 'avc1.42C01F' })); // not a keyframe: cannot start the new stream
  assert.equal(d.counts.skipped, 1);
  d.push(...packet(true, { codec: 'avc1.42C01F' }));
  await tick();
  assert.equal(decoders.length, 2);
  assert.equal(decoders[0].state, 'closed');
  assert.equal(decoders[1].config.codec, 'avc1.42C01F');
});

test('other cameras’ packets are ignored; a gap in seq is counted with whether a keyframe followed it', async () => {
  const { platform, decoders } = fakePlatform();
  const d = new H264Decoder(platform, wire(host()));
  d.start(CAMERA);
  d.push(...packet(true, { identifier: 'robot2/camera/front' }));
  assert.equal(d.counts.packets, 0);
  d.push(...packet(true, { seq: 10 }));
  await tick();
  d.push(...packet(false, { seq: 11 }));
  d.push(...packet(true, { seq: 20 })); // the relay dropped 12-19 and resumed at a keyframe
  assert.deepEqual([d.counts.gaps, d.counts.gapKeyframes], [1, 1]);
  assert.equal(decoders[0].chunks.length, 3);
});

test('stopping and starting a camera discards what was in flight', async () => {
  const { platform, decoders } = fakePlatform();
  const d = new H264Decoder(platform, wire(host()));
  d.start(CAMERA);
  d.push(...packet(true));
  d.stop(); // while the support check runs
  await tick();
  assert.equal(decoders.length, 0);
  assert.equal(d.phase, 'idle');
  d.start(CAMERA);
  d.push(...packet(true));
  assert.equal(decoders.length, 1, 'the answer came meanwhile and is remembered');
  d.push(...packet(false));
  d.start('robot2/camera/front');
  decoders[0].flush(); // outputs of the old stream
  assert.equal(d.take(), null);
  assert.equal(d.counts.decoded, 0);
});

test('the codec: H.264 only when the relay offers it, the browser decodes it and nobody forced JPEG', () => {
  const camera = { identifier: CAMERA, codecs: ['jpeg', 'h264'] };
  const here = { hasDecoder: true, forced: null, refused: new Set() };
  assert.equal(streamCodec(camera, here), 'h264');
  assert.equal(streamCodec({ identifier: CAMERA, codecs: ['jpeg'] }, here), 'jpeg');
  assert.equal(streamCodec({ identifier: CAMERA }, here), 'jpeg', 'a relay from before #16 lists no codecs');
  assert.equal(streamCodec(camera, { ...here, hasDecoder: false }), 'jpeg');
  assert.equal(streamCodec(camera, { ...here, forced: 'jpeg' }), 'jpeg');
  assert.equal(streamCodec(camera, { ...here, refused: new Set([CAMERA]) }), 'jpeg');
  assert.equal(streamCodec(null, here), 'jpeg');
});

test('a decoder that fails at every keyframe gives up: the stream is called undecodable, not asked for forever', async () => {
  const { platform, decoders } = fakePlatform();
  const h = host();
  const d = new H264Decoder(platform, wire(h));
  d.start(CAMERA);
  d.push(...packet(true));
  await tick();
  decoders[0].flush(); // one picture: the count of failures in a row starts from here
  for (let i = 0; i < MAX_FAILURES; i++) {
    decoders[decoders.length - 1].fail();
    d.push(...packet(true));
  }
  assert.equal(h.restarts.length, MAX_FAILURES - 1);
  assert.equal(h.unsupported.length, 1);
  assert.match(h.unsupported[0], /^avc1\.42C01E \(3 decoder errors in a row: Decoding error\.\)$/);
  assert.equal(d.phase, 'unsupported');
  assert.equal(decoders.length, MAX_FAILURES, 'no decoder after giving up');
});

test('every decoded picture is timed with its own packet’s stamp, dropped ones too; the ring keeps the newest', async () => {
  const { platform, decoders } = fakePlatform();
  const times = new PictureTimes(3);
  let clock = 1000;
  const d = new H264Decoder(platform, { ...wire(host()), decoded: (header) => times.record(header.stamp, clock++) });
  d.start(CAMERA);
  const sent = [packet(true), packet(false), packet(false), packet(false)];
  d.push(...sent[0]);
  await tick();
  for (const p of sent.slice(1)) d.push(...p);
  decoders[0].flush();
  assert.equal(d.counts.dropped, 3, 'three were replaced before the page took them, and still decoded');
  assert.deepEqual(
    times.recent(10),
    sent.slice(1).map(([h], i) => [h.stamp, 1001 + i]),
    'the last three of four, oldest first',
  );
  assert.deepEqual(times.recent(1), [[sent[3][0].stamp, 1003]]);
});
