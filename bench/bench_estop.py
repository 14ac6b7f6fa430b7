"""Emergency stop, end to end: from the estop frame leaving the operator to the base's first zero through the
watchdog, and to Nav2's answer to the relay's cancel (issue #27).

Per stack (sim; DDS with tools/fake_fleet.py --nav2; Zenoh with tools/fake_fleet.py --zenoh --nav2), the relay in
a process of its own as users run it: robot2 is sent to (9, 6); once it rolls, the estop leaves; the base's
commands are timed where the base is (bench/base_probe.py, over DDS or Zenoh), and the `<robot>/nav` message saying
Nav2 confirmed the cancel where the operator is. Then reset, and again. The sim has no base topic: its figure is
the ack, the relay having stopped the simulated robot before it answers.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import secrets
import signal
import socket
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import orjson
from websockets.asyncio.client import ClientConnection, connect

from .common import ROOT, Child, JsonDict, Report, Settings, child_env, new_ros_domain, ros_env, summary, target

NAME = "estop"
TITLE = "Emergency stop: frame to the base's first zero, and to Nav2's cancel answer"
ROBOT = "robot2"
#: The promise of docs/reliability.md: the base's first zero (the robot's stop) within this of the estop frame.
TARGET_ZERO_MS = 300.0


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


async def listening(port: int, within: float) -> None:
    """Until something accepts TCP connections on 127.0.0.1:``port``."""
    deadline = time.monotonic() + within
    while True:
        try:
            _, writer = await asyncio.open_connection("127.0.0.1", port)
        except OSError:
            if time.monotonic() > deadline:
                raise TimeoutError(f"nothing listens on 127.0.0.1:{port} after {within:g} s") from None
            await asyncio.sleep(0.2)
            continue
        writer.close()
        return


class Operator:
    """A WebSocket operator that keeps every message with the monotonic time it arrived."""

    def __init__(self, ws: ClientConnection) -> None:
        self.ws = ws
        self.messages: list[tuple[float, JsonDict]] = []
        self._ids = 0
        self._reader = asyncio.ensure_future(self._read())

    async def _read(self) -> None:
        with contextlib.suppress(Exception):
            async for data in self.ws:
                if isinstance(data, str):
                    parsed = orjson.loads(data)
                    for message in parsed if isinstance(parsed, list) else [parsed]:
                        self.messages.append((time.monotonic(), message))

    async def send(self, message: JsonDict) -> str:
        self._ids += 1
        rid = f"b{self._ids}"
        await self.ws.send(orjson.dumps({**message, "id": rid}).decode())
        return rid

    async def until(self, predicate: Any, within: float, start: int = 0) -> tuple[float, JsonDict]:
        deadline = time.monotonic() + within
        index = start
        while time.monotonic() < deadline:
            while index < len(self.messages):
                at, message = self.messages[index]
                index += 1
                if predicate(message):
                    return at, message
            await asyncio.sleep(0.002)
        raise TimeoutError(f"no expected message within {within} s")

    async def close(self) -> None:
        await self.ws.close()
        self._reader.cancel()


async def relay(args: list[str], env: dict[str, str]) -> tuple[asyncio.subprocess.Process, str]:
    """The relay as users run it, a lab bench's (the token alone: no accounts file made or read); its address."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", *args, "--no-accounts", "--port", "0", cwd=ROOT, env=env,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL,
    )  # fmt: skip
    assert process.stdout is not None
    line = (await asyncio.wait_for(process.stdout.readline(), 120)).decode()
    if "open " not in line:
        raise RuntimeError(f"the relay did not start: {line!r}")
    return process, line.split("open ")[1].split("/#")[0]


async def stop_relay(process: asyncio.subprocess.Process | None) -> None:
    """The relay stopped as its service manager would: SIGTERM (it stops its robots), then SIGKILL after 10 s."""
    if process is None or process.returncode is not None:
        return
    process.send_signal(signal.SIGTERM)
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(process.wait(), 10)
    if process.returncode is None:
        process.kill()


async def trial(op: Operator, probe: Child | None) -> JsonDict:
    """One goal, one estop, one reset: the delays in seconds from the estop frame's departure."""
    _, here = await op.until(lambda m: m["identifier"] == f"{ROBOT}/pose", 30, max(0, len(op.messages) - 50))
    # Up the room and back down, whichever is farther from where the last estop left the robot.
    goal = (9.0, 6.0) if here["y"] < 3.8 else (9.0, 1.5)
    start = len(op.messages)
    await op.send({"identifier": f"{ROBOT}/goal_pose", "x": goal[0], "y": goal[1]})
    _, first = await op.until(lambda m: m["identifier"] == f"{ROBOT}/pose", 30, start)
    await op.until(
        lambda m: m["identifier"] == f"{ROBOT}/pose" and math.hypot(m["x"] - first["x"], m["y"] - first["y"]) > 0.3,
        60,
        start,
    )  # rolling
    mark, probed = len(op.messages), len(probe.lines) if probe is not None else 0
    sent = time.monotonic()
    rid = await op.send({"identifier": "estop"})
    acked, reply = await op.until(lambda m: m.get("id") == rid, 10, mark)
    result: JsonDict = {"ack": acked - sent, "ok": reply["identifier"] == "ack"}
    if probe is not None:
        zero = await probe.wait_for(
            lambda line: line.get("t", 0.0) >= sent and line["linear"] == 0.0 and line["angular"] == 0.0, 5, probed
        )
        result["zero"] = zero["t"] - sent
        confirmed = await op.until(
            lambda m: m["identifier"] == f"{ROBOT}/nav" and m.get("confirmed") is not None, 5, mark
        )
        result["cancel_answer"] = confirmed[0] - sent
        result["confirmed"] = confirmed[1]["confirmed"]
    await asyncio.sleep(1.0)
    await op.send({"identifier": "estop", "action": "reset"})
    await asyncio.sleep(0.5)
    return result


async def one_stack(stack: str, trials: int, report: Report) -> JsonDict:
    token = secrets.token_urlsafe(24)
    with tempfile.TemporaryDirectory(prefix="xr-bench-estop-") as tmp:
        fleet: Child | None = None
        probe: Child | None = None
        process = None
        base_args = ["--config", str(ROOT / "robots.yaml"), "--token", token, "--audit-log", ""]
        base_args += ["--database", str(Path(tmp) / "i.sqlite")]
        try:
            if stack == "sim":
                env = child_env()
                process, url = await relay(["--backend", "sim", *base_args], env)
            elif stack == "dds":
                env = ros_env(new_ros_domain())
                fleet = await Child.start("estop-fleet", ["tools/fake_fleet.py", "--nav2"], env)
                probe_args = ["-m", "bench.base_probe", "--topic", f"/{ROBOT}/cmd_vel"]
                probe = await Child.start("estop-probe", probe_args, env)
                process, url = await relay(["--backend", "ros", *base_args], env)
            else:
                env = child_env()
                port = free_port()
                endpoint = f"tcp/127.0.0.1:{port}"
                fleet = await Child.start(
                    "estop-fleet", ["tools/fake_fleet.py", "--zenoh", "--nav2", "--listen", endpoint], env
                )
                await listening(port, 60)  # the fleet's router: a relay that finds none waits for it
                probe = await Child.start(
                    "estop-probe", ["-m", "bench.base_probe", "--topic", f"/{ROBOT}/cmd_vel", "--zenoh", endpoint], env
                )
                process, url = await relay(["--backend", "zenoh", "--zenoh-connect", endpoint, *base_args], env)
            if probe is not None:
                await probe.wait_for(lambda line: line.get("ready") is True, 60)
            op = Operator(await connect(url.replace("http", "ws") + f"/ws?token={token}", max_size=None))
            results = [await trial(op, probe) for _ in range(trials)]
            await op.close()
        finally:
            await stop_relay(process)
            for child in (probe, fleet):
                if child is not None:
                    await child.stop()
    out: JsonDict = {"trials": results, "ack_ms": summary([r["ack"] for r in results])}
    if probe is not None:
        out["zero_ms"] = summary([r["zero"] for r in results])
        out["cancel_answer_ms"] = summary([r["cancel_answer"] for r in results])
        out["confirmed"] = sum(1 for r in results if r["confirmed"])
    line = f"{stack}: ack p50 {out['ack_ms']['p50']} ms"
    if probe is not None:
        line += f", base's first zero p50 {out['zero_ms']['p50']} ms max {out['zero_ms']['max']} ms"
        line += f", Nav2's cancel answer p50 {out['cancel_answer_ms']['p50']} ms ({out['confirmed']} confirmed)"
    report.line(line)
    return out


async def run(settings: Settings, report: Report) -> JsonDict:
    trials = int(settings.pick(8, 2))
    stacks: JsonDict = {}
    for stack in ("sim", "dds", "zenoh"):
        try:
            stacks[stack] = await one_stack(stack, trials, report)
        except Exception as exc:  # one stack that cannot run (no rclpy, no zenoh) must not hide the others
            stacks[stack] = {"error": f"{type(exc).__name__}: {exc}"}
            report.line(f"{stack}: FAILED {exc!r}")
    targets = []
    for stack, result in stacks.items():
        if "error" in result:
            targets.append(target(f"{stack}: estop", "measured", "not measured", None, result["error"]))
            continue
        if "zero_ms" in result:
            worst = result["zero_ms"]["max"]
            targets.append(
                target(
                    f"{stack}: estop frame to the base's first zero (through the watchdog)",
                    f"< {TARGET_ZERO_MS:g} ms, every trial",
                    f"p50 {result['zero_ms']['p50']} ms, max {worst} ms",
                    worst is not None and worst < TARGET_ZERO_MS,
                    baseline=f"ack p50 {result['ack_ms']['p50']} ms",
                )
            )
            targets.append(
                target(
                    f"{stack}: estop frame to Nav2's answer to the cancel (at the operator)",
                    "reported (no target given)",
                    f"p50 {result['cancel_answer_ms']['p50']} ms, max {result['cancel_answer_ms']['max']} ms, "
                    f"{result['confirmed']}/{len(result['trials'])} confirmed",
                    None,
                )
            )
        else:
            worst = result["ack_ms"]["max"]
            targets.append(
                target(
                    f"{stack}: estop frame to its ack (the robot stopped before it)",
                    f"< {TARGET_ZERO_MS:g} ms, every trial",
                    f"p50 {result['ack_ms']['p50']} ms, max {worst} ms",
                    worst is not None and worst < TARGET_ZERO_MS,
                )
            )
    return {
        "parameters": {"robot": ROBOT, "trials": trials, "cpus": os.cpu_count()},
        "stacks": stacks,
        "targets": targets,
    }
