"""Inspection missions end to end on the sim, over /ws: the demo mission runs without a hand on the stick, goes on
when its operator's client is killed, and leaves three findings with images in the database and the report; bad
missions are refused before any robot moves; viewers create nothing; an estop holds a mission until the reset."""

from __future__ import annotations

import asyncio
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import aiohttp

from relay.config import FleetConfig
from relay.inspection.kml import Georeference, to_map
from relay.inspection.store import Store
from tests.helpers.inspection import TOKEN, missions, operator, relay_with_database
from tests.wsclient import TestClient


async def test_the_demo_mission_survives_its_operator_and_leaves_three_findings(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        first = await operator(running)
        targets = await first.wait_for(lambda m: m["identifier"] == "targets")
        assert sorted(t["id"] for t in targets["targets"]) == ["leak", "panels", "spill"]
        reply = await first.request({"identifier": "mission/start", "file": "demo"}, timeout=30)
        assert reply["identifier"] == "ack", reply
        await first.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running")
        started = missions(first)
        assert {m["robot"]: m["steps"][0]["target"] for m in started.values()} == {
            "robot1": "spill", "robot2": "panels", "robot3": "leak",
        }  # fmt: skip
        group = next(iter(started)).split(".")[0]
        await asyncio.sleep(1.0)
        first.ws.transport.abort()  # the operator's client dies mid-mission
        await asyncio.sleep(1.0)
        second = await operator(running)
        await second.wait_for(lambda m: m["identifier"] == "mission")
        assert all(m["state"] == "running" for m in missions(second).values()), missions(second)
        for _ in range(180):  # up to 90 s: the robots cross their rooms at 0.6 m/s
            if all(m["state"] == "done" for m in missions(second).values()):
                break
            await asyncio.sleep(0.5)
        assert all(m["state"] == "done" for m in missions(second).values()), missions(second)
        findings = [m for _, m in second.messages if m["identifier"] == "finding"]
        by_target = {f["target"]: f for f in findings}
        assert sorted(by_target) == ["leak", "panels", "spill"]
        # The sim's hazards: the spill's gas and the leak's humidity are over their thresholds; the panels are warm
        # but under 45 degC.
        assert (by_target["spill"]["status"], by_target["leak"]["status"]) == ("anomaly", "anomaly")
        assert by_target["panels"]["status"] == "ok"
        assert "gas" in by_target["spill"]["note"] and "humidity" in by_target["leak"]["note"]
        # A target from a pixel: the centre of the spill's image, where the robot looked.
        spill = by_target["spill"]
        added = await second.request(
            {"identifier": "target/add", "target": "drum-3", "capture": spill["capture"], "u": 239.5, "v": 300}
        )
        assert added["identifier"] == "ack", added
        drum = second.targets()["drum-3"]
        assert 0.5 < drum["x"] < 3.0 and 6.5 < drum["y"] < 9.0, drum  # in front of the spill's standoff pose
        async with aiohttp.ClientSession() as http:
            for finding in findings:
                async with http.get(f"{running.url}{finding['image']}?token={TOKEN}") as response:
                    assert response.status == 200 and (await response.read()).startswith(b"\xff\xd8")
            async with http.get(f"{running.url}{findings[0]['image']}") as response:
                assert response.status == 200  # without a token: this relay allows viewers, who see findings
            async with http.get(f"{running.url}/report/{group}.html?token={TOKEN}") as response:
                report = await response.text()
                assert response.status == 200
            async with http.get(f"{running.url}/report/{group}.csv?token={TOKEN}") as response:
                rows = (await response.text()).strip().splitlines()
        assert report.count("data:image/jpeg;base64,") == 3 and "3 findings: 1 OK, 2 anomalies." in report
        assert len(rows) == 4 and rows[0].startswith("finding,status")
        await second.close()
    finally:
        await running.runner.cleanup()
    # The database outlives the relay: three findings with their images.
    store = Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images")
    stored = store.findings()
    assert len(stored) == 3 and all(store.image(store.capture(f.capture).image or "") for f in stored)  # type: ignore[union-attr]
    assert {m.state for m in store.missions()} == {"done"}
    store.close()


async def test_bad_missions_are_refused_before_any_robot_moves(fleet_config: FleetConfig, tmp_path: Path) -> None:
    missions_dir = tmp_path / "missions"
    missions_dir.mkdir()
    (missions_dir / "broken.yaml").write_text("robots:\n  - robot: robot1\n    steps: [{inspect: spill}\n")
    running = await relay_with_database(fleet_config, tmp_path, missions_dir=missions_dir)
    try:
        client = await operator(running)
        cases: list[tuple[dict[str, Any], str, str]] = [
            ({"file": "broken"}, "bad_request", "broken.yaml"),
            ({"file": "nothing"}, "bad_request", "no mission file 'nothing'; there are broken"),
            ({"targets": ["spill", "valve-9"]}, "bad_request", "unknown target(s) valve-9"),
            ({"robot": "robot1", "steps": [{"inspect": "spill"}, {"goto": {"x": 6.0, "y": 6.0}}]}, "no_path",
             "step 2 (goto): no path"),
            ({"robot": "robot1", "steps": [{"goto": {"x": 60.0, "y": 6.0}}]}, "no_path", "outside the map"),
            ({"robot": "robot9", "steps": [{"dwell": 1}]}, "unknown_robot", "robot9"),
            ({"robot": "robot1", "steps": "spill"}, "bad_request", "steps must be a list"),
            ({"targets": ["spill"], "robots": ["robot2", "robot9"]}, "unknown_robot", "unknown robot(s) robot9"),
            ({"targets": ["spill"], "robots": []}, "bad_request", "field 'robots' must be a list of 1 to 200"),
            ({"file": "broken", "robots": ["robot1"]}, "bad_request", "robots (a group) go with targets"),
        ]  # fmt: skip
        for fields, code, text in cases:
            reply = await client.request({"identifier": "mission/start", **fields}, timeout=30)
            assert (reply.get("code"), text in reply.get("message", "")) == (code, True), (fields, reply)
        assert not missions(client)
        assert all(r.follower is None for r in running.relay.backend.world.robots.values())  # type: ignore[attr-defined]
        viewer = await TestClient.open(running.ws_url)
        await viewer.hello()
        for fields in (
            {"identifier": "mission/start", "file": "broken"},
            {"identifier": "target/add", "target": "x", "x": 1, "y": 1},
        ):
            assert (await viewer.request(fields))["code"] == "forbidden"
        await viewer.close()
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_targets_for_a_group_go_to_its_robots_alone(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """A team's or a room's robots (``robots``): the targets are shared out among them, nearest first, and the
    robot outside the group, though it stands nearest to the spill, is not sent."""
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        group = ["robot2", "robot3"]
        reply = await client.request(
            {"identifier": "mission/start", "targets": ["spill", "leak"], "robots": group, "name": "east"}, timeout=30
        )
        assert reply["identifier"] == "ack", reply
        await client.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running")
        sent = {m["robot"]: m for m in missions(client).values()}
        assert sorted(sent) == group, sent
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_an_estop_holds_a_mission_until_the_reset_and_a_take_over_pauses_it(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        first = await operator(running)
        steps = [{"goto": {"x": 3.0, "y": 2.5}}, {"dwell": 30}]
        assert (await first.request({"identifier": "mission/start", "robot": "robot1", "steps": steps}))[
            "identifier"
        ] == "ack"
        await first.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running")
        [mission_id] = missions(first)
        # Another operator takes robot1 over by force: the mission pauses, and says why.
        second = await operator(running)
        assert (await second.request({"identifier": "robot1/lease", "force": True}))["identifier"] == "ack"
        paused = await first.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "paused")
        assert "takes over" in paused["reason"]
        # The holder hands it back with resume; then an estop aborts it.
        assert (await second.request({"identifier": "mission/resume", "mission": mission_id}))["identifier"] == "ack"
        await first.wait_for(
            lambda m: m["identifier"] == "mission" and m["state"] == "running", start=len(first.messages) - 5
        )
        mark = len(first.messages)
        assert (await first.request({"identifier": "estop"}))["identifier"] == "ack"
        held = await first.wait_for(lambda m: m["identifier"] == "mission" and "held" in m["reason"], start=mark)
        assert held["reason"].startswith("emergency stop by") and "held" in held["reason"]
        # Held while latched: it cannot be resumed before the reset, and keeps its robot meanwhile.
        reply = await first.request({"identifier": "mission/resume", "mission": mission_id})
        assert reply["code"] == "estopped", reply
        assert running.relay.control.leases.holder("robot1") == f"mission:{mission_id}"
        assert (await first.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        reply = await first.request({"identifier": "mission/resume", "mission": mission_id})
        assert reply["identifier"] == "ack", reply
        await first.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running", start=mark)
        assert (await first.request({"identifier": "mission/abort", "mission": mission_id}))["identifier"] == "ack"
        assert running.relay.control.leases.holder("robot1") is None  # the mission let go of the robot
        reply = await first.request({"identifier": "mission/resume", "mission": mission_id})
        assert reply["code"] == "bad_request" and "ended" in reply["message"]
        for client in (first, second):
            await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_kmz_of_placemarks_becomes_a_fleet_mission(fleet_config: FleetConfig, tmp_path: Path) -> None:
    import simplekml  # type: ignore[import-untyped]

    geo = Georeference(lat=48.137, lon=11.575)
    north = to_map(geo, geo.lat + 1e-4, geo.lon)[1] / 1e-4  # metres per degree, as the importer computes them
    east = to_map(geo, geo.lat, geo.lon + 1e-4)[0] / 1e-4
    kml = simplekml.Kml()
    for name, (x, y) in {"Drum 7": (1.8, 8.2), "Valve 12": (15.6, 7.6)}.items():  # the spill and the leak
        point = kml.newpoint(name=name, coords=[(geo.lon + x / east, geo.lat + y / north)])
        point.extendeddata.newdata("kind", "drum" if name.startswith("Drum") else "valve")
    missions_dir = tmp_path / "missions"
    missions_dir.mkdir()
    kml.savekmz(str(missions_dir / "rounds.kmz"))
    running = await relay_with_database(replace(fleet_config, georeference=geo), tmp_path, missions_dir=missions_dir)
    try:
        client = await operator(running)
        reply = await client.request({"identifier": "mission/start", "file": "rounds"}, timeout=30)
        assert reply["identifier"] == "ack", reply
        targets = list(client.targets().values())
        placed = {t["id"]: (round(t["x"], 2), round(t["y"], 2), t["kind"]) for t in targets}
        assert placed["drum-7"] == (1.8, 8.2, "drum") and placed["valve-12"] == (15.6, 7.6, "valve")
        await client.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running")
        assert {m["robot"]: m["steps"][0]["target"] for m in missions(client).values()} == {
            "robot1": "drum-7", "robot3": "valve-12",
        }  # fmt: skip
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        await client.close()
    finally:
        await running.runner.cleanup()
    # Without a georeference the same file is refused, saying what to add.
    running = await relay_with_database(fleet_config, tmp_path / "second", missions_dir=missions_dir)
    try:
        client = await operator(running)
        reply = await client.request({"identifier": "mission/start", "file": "rounds"}, timeout=30)
        assert reply["code"] == "bad_request" and "add a georeference to robots.yaml" in reply["message"], reply
        assert not missions(client)
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_locked_database_refuses_the_mission_naming_it_and_no_robot_moves(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    import sqlite3

    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        other = sqlite3.connect(tmp_path / "inspection.sqlite", isolation_level=None)  # another process's lock
        other.execute("BEGIN EXCLUSIVE")
        reply = await client.request({"identifier": "mission/start", "file": "demo"}, timeout=30)
        assert reply["code"] == "internal" and "inspection.sqlite is locked" in reply["message"], reply
        assert all(r.follower is None for r in running.relay.backend.world.robots.values())  # type: ignore[attr-defined]
        other.execute("ROLLBACK")
        other.close()
        reply = await client.request({"identifier": "mission/start", "file": "demo"}, timeout=30)
        assert reply["identifier"] == "ack", reply  # works again once the lock is gone
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_pixel_of_the_live_camera_becomes_a_target_a_finding_to_review_and_a_proposed_region(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """What a gaze dwell on the live hemisphere sends (issue #17): robot1 looks along its heading; the pixel below
    its image's centre looks at the floor a little ahead of it. The relay captures the camera now, adds the target
    there, makes a finding to review about that capture, and proposes the region around the pixel before the ack."""
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        camera = fleet_config.robots[0].cameras[0]
        await asyncio.sleep(0.5)  # the sim's first rendered frame
        reply = await client.request(
            {"identifier": "target/add", "target": "spot-1", "robot": "robot1",
             "u": camera.width / 2, "v": camera.height * 0.75},
            timeout=30,
        )  # fmt: skip
        assert reply["identifier"] == "ack", reply
        finding = next(m for _, m in client.messages if m["identifier"] == "finding" and m["target"] == "spot-1")
        store = running.relay.inspection.store
        assert store is not None
        capture = store.capture(finding["capture"])
        assert capture is not None and capture.robot == "robot1" and capture.width == camera.width
        pose = {"x": capture.x, "y": capture.y, "yaw": capture.yaw}
        targets = list(client.targets().values())
        spot = next(t for t in targets if t["id"] == "spot-1")
        ahead = (spot["x"] - pose["x"]) * math.cos(pose["yaw"]) + (spot["y"] - pose["y"]) * math.sin(pose["yaw"])
        aside = -(spot["x"] - pose["x"]) * math.sin(pose["yaw"]) + (spot["y"] - pose["y"]) * math.cos(pose["yaw"])
        assert 0.2 < ahead < 3.0 and abs(aside) < 0.2, (spot, pose)  # on the floor straight ahead
        assert (finding["status"], finding["source"], finding["robot"]) == ("needs_review", "operator", "robot1")
        assert "gas" in finding["readings"] and "robot1" in finding["note"], finding
        region = next(m for _, m in client.messages if m["identifier"] == "region")
        assert region["id"] == reply["id"] and region["capture"] == finding["capture"]
        assert len(region["outline"]) >= 3, region
        url = f"{running.url}{finding['image']}?token={TOKEN}"
        async with aiohttp.ClientSession() as http, http.get(url) as response:
            assert response.status == 200 and (await response.read()).startswith(b"\xff\xd8")
        # Refused, naming why, and nothing added or stored: an unknown robot, a pixel outside the fisheye's circle, a
        # viewer.
        captures = len(store.captures())
        for fields, code, text in (
            ({"robot": "robot9", "u": 10, "v": 10}, "unknown_robot", "robot9"),
            ({"robot": "robot1", "u": 2, "v": 2}, "bad_request", "outside the field of camera 'front'"),
            ({"robot": "robot1", "u": 10}, "bad_request", "'v'"),
        ):
            refused = await client.request({"identifier": "target/add", "target": "spot-2", **fields}, timeout=30)
            assert (refused.get("code"), text in refused.get("message", "")) == (code, True), (fields, refused)
        # Each takes a snapshot: an operator may have two at once (relay/session/budget.py); a third is refused at once.
        asked = [
            {"identifier": "target/add", "target": f"burst-{k}", "robot": "robot1", "u": 240, "v": 360}
            for k in range(3)
        ]
        replies = await asyncio.gather(*(client.request(m, timeout=30) for m in asked))
        busy = [r for r in replies if r.get("code") == "busy"]
        assert len(busy) == 1 and "2 snapshot(s) of this client already in progress" in busy[0]["message"], replies
        captures += 2
        viewer = await TestClient.open(running.ws_url)
        await viewer.hello()
        refused = await viewer.request(
            {"identifier": "target/add", "target": "spot-2", "robot": "robot1", "u": 240, "v": 300}
        )
        assert refused.get("code") == "forbidden", refused
        await asyncio.sleep(0.3)
        targets = list(client.targets().values())
        assert "spot-2" not in {t["id"] for t in targets}
        assert len(store.captures()) == captures
        await viewer.close()
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_restarted_relay_shows_what_it_had_and_a_held_mission_resumes_where_it_was(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """Issue #30: after a restart the page showed "Findings (0)" while the database held 13 findings and 10
    missions, and targets operators had added were gone; an estop aborted a mission for good. Now a relay started on
    the same database shows every target, finding (with its image) and mission as before, and a mission an estop
    held resumes from the step it was at."""
    camera = fleet_config.robots[0].cameras[0]
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        await asyncio.sleep(0.5)  # the sim's first rendered frame
        spot = {"identifier": "target/add", "target": "spot-1", "robot": "robot1",
                "u": camera.width / 2, "v": camera.height * 0.75}  # fmt: skip
        assert (await client.request(spot, timeout=30))["identifier"] == "ack"
        pose = {"identifier": "target/add", "target": "drum-9", "name": "Drum 9", "kind": "drum", "x": 2.0, "y": 8.0}
        assert (await client.request(pose))["identifier"] == "ack"
        steps = [{"goto": {"x": 3.0, "y": 2.0}}, {"dwell": 30}, {"goto": {"x": 3.0, "y": 2.5}}]
        reply = await client.request({"identifier": "mission/start", "robot": "robot1", "steps": steps}, timeout=30)
        assert reply["identifier"] == "ack", reply
        await client.wait_for(lambda m: m["identifier"] == "mission" and m["current"] == 1, timeout=30)  # dwelling
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        await client.wait_for(lambda m: m["identifier"] == "mission" and "held" in m["reason"])
        before = {
            "targets": client.targets(),
            "findings": {m["id"]: m for _, m in client.messages if m["identifier"] == "finding"},
            "missions": missions(client),
        }
        await client.close()
    finally:
        await running.runner.cleanup()

    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        await client.wait_for(lambda m: m["identifier"] == "mission")
        assert client.targets() == before["targets"]  # the scene's, the point and the pixel's
        findings = {m["id"]: m for _, m in client.messages if m["identifier"] == "finding"}
        assert findings == before["findings"] and findings
        async with aiohttp.ClientSession() as http:
            for finding in findings.values():
                async with http.get(f"{running.url}{finding['image']}?token={TOKEN}") as response:
                    assert response.status == 200 and (await response.read()).startswith(b"\xff\xd8")
        [(mission_id, mission)] = missions(client).items()
        assert mission == before["missions"][mission_id]  # held, at its second step, as it was left
        mark = len(client.messages)
        reply = await client.request({"identifier": "mission/resume", "mission": mission_id}, timeout=30)
        assert reply["identifier"] == "ack", reply
        resumed = await client.wait_for(lambda m: m["identifier"] == "mission", start=mark)
        assert (resumed["state"], resumed["current"]) == ("running", 1)  # from the dwell it was at
        assert (await client.request({"identifier": "mission/abort", "mission": mission_id}))["identifier"] == "ack"
        await client.close()
    finally:
        await running.runner.cleanup()
