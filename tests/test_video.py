"""Live H.264 video (#16, relay side): relay/media/video.py's encoder, the hub's video lane, and a sim camera streamed
as video over a real WebSocket, every packet decoded by an independent decoder (FFmpeg's h264 through PyAV).

The images are the real fisheye photo of shared/data panned across (so the encoder has motion to code)."""

from __future__ import annotations

import asyncio
import socket
import time
from typing import Any

import av
import cv2
import numpy as np
import pytest
from websockets.asyncio.client import connect

from relay.media.video import H264Encoder, VideoError, codec_string
from relay.station.hub import Hub
from relay.station.messages import FrameHeader, encode_frame
from tests.conftest import RunningRelay, shared_data
from tests.helpers.hub import RecordingTransport, settle
from tests.wsclient import TestClient

FISHEYE = ("fisheye", "surroundvision_jeyp4", "front.jpg")  # in the shared data


def panning(width: int, height: int, count: int) -> list[np.ndarray]:
    """``count`` BGR frames of the photo, panned 6 pixels a frame."""
    photo = cv2.imread(str(shared_data(*FISHEYE)))
    assert photo is not None
    wide = cv2.resize(photo, (width + 6 * count, height + 40))
    return [np.ascontiguousarray(wide[20 : 20 + height, 6 * i : 6 * i + width]) for i in range(count)]


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return 99.0 if mse == 0 else 10 * np.log10(255.0**2 / mse)


def test_the_encoder_makes_a_stream_an_independent_decoder_reads_frame_by_frame() -> None:
    frames = panning(640, 480, 45)
    encoder = H264Encoder(640, 480, 30.0)
    decoder: Any = av.CodecContext.create("h264", "r")
    sizes, keyframes, qualities = [], [], []
    for i, image in enumerate(frames):
        packets = encoder.encode(image, 100.0 + i / 30, keyframe=i == 20)
        assert len(packets) == 1, "zerolatency: one packet per frame, at once"
        packet = packets[0]
        sizes.append(len(packet.data))
        keyframes.append(packet.keyframe)
        assert packet.codec.startswith("avc1.42"), packet.codec  # constrained baseline
        decoded = decoder.decode(av.Packet(packet.data))
        assert len(decoded) == 1, f"frame {i} did not decode by itself"
        qualities.append(psnr(decoded[0].to_ndarray(format="bgr24"), image))
    assert keyframes[0] and keyframes[20] and sum(keyframes) == 2  # the first, and the one asked for (GOP = 1 s)
    assert min(qualities) > 27.0, qualities  # dB (measured 28.7-31 at 833 kbit/s): the picture, not noise
    assert sum(sizes) / 1.5 < 640 * 480 * 3 * 30 / 50, "at least 50 times smaller than raw RGB"
    assert codec_string(b"\x00\x00\x00\x01\x67\x42\xc0\x1e") == "avc1.42C01E"
    encoder.close()


def test_a_camera_of_odd_size_cannot_be_video_and_says_why() -> None:
    with pytest.raises(VideoError, match="641x480"):
        H264Encoder(641, 480, 30.0)
    encoder = H264Encoder(640, 480, 30.0)
    with pytest.raises(VideoError, match="640x480"):
        encoder.encode(np.zeros((480, 320, 3), np.uint8), 1.0)


async def test_a_video_lane_that_drops_a_packet_waits_for_the_next_keyframe() -> None:
    hub = Hub(max_video=3)
    stalled = RecordingTransport()
    stalled.gate.clear()  # this client reads nothing for now
    channel = hub.add("c1", stalled)
    hub.set_stream(channel, "robot1/camera/front", 30.0, "h264")
    assert hub.publish_video("robot1/camera/front", b"p0", keyframe=False) == (1, 1), "a new viewer starts at a key"
    assert hub.publish_video("robot1/camera/front", b"k1", keyframe=True) == (1, 0)
    await settle()  # the writer takes k1 and blocks on the socket
    for i in range(2, 6):
        hub.publish_video("robot1/camera/front", b"p%d" % i, keyframe=False)
    # The writer took k1 and waits on the socket; the lane holds p2, p3, p4; p5 could not be queued: the stream is
    # broken until a keyframe, and p6 is not queued either (a decoder could not use it).
    assert hub.publish_video("robot1/camera/front", b"p6", keyframe=False) == (1, 1)
    stalled.gate.set()  # the client reads again
    await settle()
    assert hub.publish_video("robot1/camera/front", b"p7", keyframe=False) == (1, 1)
    assert hub.publish_video("robot1/camera/front", b"k8", keyframe=True) == (1, 0)
    await settle()
    sent = [d for _, d in stalled.sent]
    assert sent == [b"k1", b"p2", b"p3", b"p4", b"k8"], sent  # never a P-frame after a gap
    assert hub.counters.video_dropped == 4  # p0 (before any key), p5, p6, p7


async def client_of(relay: RunningRelay) -> TestClient:
    client = await TestClient.open(relay.ws_url)
    await client.hello()
    return client


async def video_frames(client: TestClient, identifier: str, count: int, timeout: float = 30.0) -> list[Any]:
    deadline = time.monotonic() + timeout
    frames: list[Any] = []
    while time.monotonic() < deadline:
        frames = [(h, p) for _, h, p in client.frames if h["identifier"] == identifier and h["encoding"] == "h264"]
        if len(frames) >= count:
            return frames
        await asyncio.sleep(0.1)
    raise AssertionError(f"{len(frames)} of {count} video frames of {identifier} in {timeout} s")


async def test_a_sim_camera_streams_as_h264_beside_a_jpeg_viewer(relay_server: RunningRelay) -> None:
    video, jpeg = await TestClient.open(relay_server.ws_url), await TestClient.open(relay_server.ws_url)
    hello = await video.hello()
    await jpeg.hello()
    try:
        camera = hello["robots"][0]["cameras"][0]
        assert camera["codecs"] == ["jpeg", "h264"]
        reply = await video.request({"identifier": "robot1/stream", "camera": "front", "fps": 10, "codec": "h264"})
        assert reply["identifier"] == "ack", reply
        reply = await jpeg.request({"identifier": "robot1/stream", "camera": "front", "fps": 10})
        assert reply["identifier"] == "ack", reply
        frames = await video_frames(video, "robot1/camera/front", 8)
        assert frames[0][0]["keyframe"] is True and frames[0][0]["codec"].startswith("avc1.")
        decoder: Any = av.CodecContext.create("h264", "r")
        for header, payload in frames:
            assert (header["width"], header["height"]) == (camera["width"], camera["height"])
            (picture,) = decoder.decode(av.Packet(payload))
            assert (picture.width, picture.height) == (camera["width"], camera["height"])
        jpegs = [h for _, h, _ in jpeg.frames if h["identifier"] == "robot1/camera/front"]
        assert jpegs and all(h["encoding"] == "jpeg" for h in jpegs), "the JPEG viewer still gets JPEG"
        assert all(h["encoding"] == "h264" for _, h, _ in video.frames if h["identifier"] == "robot1/camera/front")
    finally:
        await video.close()
        await jpeg.close()


async def test_a_codec_that_does_not_exist_is_refused_by_name_and_nothing_streams(relay_server: RunningRelay) -> None:
    client = await client_of(relay_server)
    try:
        reply = await client.request({"identifier": "robot1/stream", "camera": "front", "fps": 10, "codec": "vp9"})
        assert reply["identifier"] == "error" and reply["code"] == "unsupported"
        assert '"vp9"' in reply["message"] and "robot1/stream" in reply["message"]
        await asyncio.sleep(1.0)
        assert client.frames == []
    finally:
        await client.close()


#: Bytes the relay may have written into a stalled viewer's connection before its video lane drops: the
#: connection's unsent kernel bytes (server.UNSENT_BYTES), asyncio's buffer (server.WRITE_BUFFER_BYTES) and what
#: the viewer's own small socket takes. Measured 63 kB; 513 kB before the relay bounded the unsent bytes (its
#: 512 kB send buffer full of them: 1.6 s of this 2.5 Mbit/s stream that a viewer would see late before the lane
#: noticed anything).
STALLED_BACKLOG = 160 * 1024


def pan_frames(identifier: str, width: int, height: int, count: int) -> list[tuple[bytes, bool]]:
    """The wire frames (header and packet) of a pan at the default bitrate, as the relay sends them."""
    encoder = H264Encoder(width, height, 30.0)
    frames = []
    for i, image in enumerate(panning(width, height, count)):
        for packet in encoder.encode(image, i / 30):
            header: FrameHeader = {
                "identifier": identifier,
                "seq": i,
                "stamp": i / 30,
                "encoding": "h264",
                "width": width,
                "height": height,
                "lens": {"model": "pinhole", "fov": 90.0},
                "request_id": None,
                "keyframe": packet.keyframe,
                "codec": packet.codec,
            }
            frames.append((encode_frame(header, packet.data), packet.keyframe))
    encoder.close()
    return frames


async def test_a_viewer_that_stops_reading_is_noticed_within_a_bounded_backlog(relay_server: RunningRelay) -> None:
    shared_data(*FISHEYE)  # skips, naming it, when the photo the pan is made of is absent
    # A viewer whose socket takes little (a slow network does the same): it reads the hello, then nothing.
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # before connect: the window it offers
    host, port = relay_server.ws_url.split("/")[2].split(":")
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, (host, int(port)))
    # max_queue=None: without it, websockets pauses and resumes reading by itself as its own queue fills and drains
    # (on a loaded machine, while the hello's burst is read), which undid the pause below and the viewer read on.
    client = TestClient(await connect(relay_server.ws_url, sock=sock, max_size=8 * 1024 * 1024, max_queue=None))
    await client.hello()
    hub = relay_server.relay.hub
    (channel,) = list(hub)
    identifier = "robot1/camera/test"
    hub.set_stream(channel, identifier, 30.0, "h264")
    client.ws.transport.pause_reading()
    # Real packets of a 1280x720 pan at the camera default's bitrate (~10 kB each), published at 30 fps.
    frames = await asyncio.to_thread(pan_frames, identifier, 1280, 720, 60)
    sent_before = hub.counters.bytes_out
    published = 0
    for i in range(10 * 30):  # at most 10 s
        data, keyframe = frames[i % len(frames)]
        hub.publish_video(identifier, data, keyframe)
        published += len(data)
        if hub.counters.video_dropped:
            break
        await asyncio.sleep(1 / 30)
    written = hub.counters.bytes_out - sent_before
    assert hub.counters.video_dropped, f"nothing dropped after {published} bytes to a viewer that reads nothing"
    assert written <= STALLED_BACKLOG, f"{written} bytes went into the stalled connection before the lane dropped"
    # It reads again: the connection delivers what was written (the relay did not lose its place).
    client.ws.transport.resume_reading()
    deadline = time.monotonic() + 10
    while not any(h["identifier"] == identifier for _, h, _ in client.frames):
        assert time.monotonic() < deadline, "the viewer got none of the stream after it read again"
        await asyncio.sleep(0.05)
    await client.close()
