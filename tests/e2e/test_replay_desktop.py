"""A recorded session replayed in the desktop page (issue #34): a relay on the simulated fleet records a desktop page
(which says where its operator looks from, 4 times a second) and a real WebSocket client driving robot1 and sending
its operator's viewpoint; `xr-relay replay`'s relay serves the file; the page shows the replay's timeline, pauses with
it, seeks with its slider, and draws the recorded operators among the robots where they were."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

import orjson
import pytest
from mcap.reader import make_reader

from relay.cli.options import Options, ReplayOptions
from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.helpers.browser import SOFTWARE_GL, OpenClient, wait_until
from tests.wsclient import TestClient

#: The recorded operator stands in the corridor between robot1 and robot2, looking at robot2, and points at it.
EYE = (5.5, 1.0, 1.6)
LOOK = (1.0, 0.0, 0.0)


def _viewer(k: int) -> dict[str, Any]:
    hand = [EYE[0] + 0.25, EYE[1] - 0.25, 1.1]
    return {
        "identifier": "viewer",
        "head": {"position": [EYE[0] + 0.01 * k, EYE[1], EYE[2]], "look": list(LOOK)},
        "hands": [{"hand": "right", "position": hand, "ray": [math.sqrt(0.5), math.sqrt(0.5), 0.0]}],
    }


async def _record(path: Path, open_client: OpenClient) -> tuple[list[dict[str, Any]], str]:
    """Record a session; returns the viewpoints the page sent (it connects first), and the client's id."""
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(backend="sim", record_session=str(path)))
    recorder = running.relay.recorder
    assert recorder is not None
    viewers: list[tuple[str, dict[str, Any]]] = []
    record = recorder.record

    def spy(topic: str, data: bytes, log_time_ns: int | None = None) -> None:
        if topic.startswith("/in/"):
            frame = orjson.loads(orjson.loads(data)["frame"])
            if frame.get("identifier") == "viewer":
                viewers.append((topic, frame))
        record(topic, data, log_time_ns)

    recorder.record = spy  # type: ignore[method-assign]
    try:
        await open_client(f"{running.url}/?{SOFTWARE_GL}", "record", 1280, 760)
        await wait_until(lambda: len(viewers) >= 2, 30, "the page's viewpoint, twice")
        client = await TestClient.open(running.ws_url)
        ana = (await client.hello())["client_id"]
        await client.request({"identifier": "name", "name": "Ana"})
        for k in range(80):  # 4 s at the page's 20 Hz teleop, the viewpoint at 4 Hz
            await client.send({"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.2})
            if k % 5 == 0:
                await client.send(_viewer(k))
            await asyncio.sleep(0.05)
        await client.close()
    finally:
        await running.runner.cleanup()
    return [frame for topic, frame in viewers if topic == viewers[0][0]], ana


def _last_viewer(path: Path, client: str) -> float:
    """When the client's last viewpoint was recorded, in s from the session's start."""
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        start = summary.statistics.message_start_time
        times = [m.log_time for _, _, m in reader.iter_messages(topics=[f"/in/{client}"]) if b"viewer" in m.data]
    return (max(times) - start) * 1e-9


async def test_a_replay_is_played_from_the_timeline_with_its_operator_drawn(
    open_client: OpenClient, tmp_path: Path
) -> None:
    path = tmp_path / "session.mcap"
    viewers, ana = await _record(path, open_client)
    # A second both operators were there: shortly before the client's last viewpoint.
    target = round(_last_viewer(path, ana) - 0.5, 1)
    assert all(v["head"]["position"][2] > 2.0 for v in viewers), [v["head"] for v in viewers]
    page = viewers[-1]
    assert page["hands"] == [], "a desktop page has no hands"
    assert math.hypot(*page["head"]["look"]) == pytest.approx(1.0, abs=0.01)
    assert page["head"]["position"][2] > 2.0, "the desktop's camera looks at the fleet from above"
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(backend="replay", replay=ReplayOptions(str(path), loop=True)))
    try:
        client = await open_client(f"{running.url}/?{SOFTWARE_GL}", "replay", 1280, 760)
        await client.wait("s.replay.bar && s.playback && !s.playback.paused", 30)
        await client.page.click("#playback-toggle")  # Pause
        await client.wait("s.playback.paused", 20)
        assert await client.page.inner_text("#playback-toggle") == "Play"
        await client.page.eval_on_selector(
            "#playback-seek",
            "(el, t) => { el.value = String(t); el.dispatchEvent(new Event('input')); "
            "el.dispatchEvent(new Event('change')); }",
            target,
        )
        await client.wait("s.playback.paused && Math.abs(s.playback.position - arg) < 0.01", 20, target)
        # The page's operator and the client's (Ana), both there at the target.
        await client.wait("s.replay.avatars.length === 2", 30)
        await client.page.keyboard.press("t")  # the top view
        await client.wait("s.view.mode === 'top'", 5)
        await client.drawn(2)
        await client.shot("01-replay-paused-with-operator")
        assert f"0:{target:04.1f}" in await client.page.inner_text("#playback-time")
        await client.page.select_option("#playback-rate", "4")
        await client.page.click("#playback-toggle")  # Play, four times as fast
        await client.wait("!s.playback.paused && s.playback.rate === 4", 20)
        assert client.errors == [], client.errors
    finally:
        await running.runner.cleanup()
