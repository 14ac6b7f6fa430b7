"""Bad frames for the /ws fuzz, generated (tests/test_fuzz.py, and its memory traced in a process of its own:
tests/helpers/ws_fuzz_memory.py)."""

from __future__ import annotations

import json
import random
from typing import Any


def mutated_frames(rng: random.Random, count: int) -> list[str | bytes]:
    """Invalid frames of every kind the issue lists, each built from a valid command by one mutation."""
    valid: list[dict[str, Any]] = [
        {"identifier": "robot1/goal_pose", "x": 3.0, "y": 6.0, "yaw": 0.5},
        {"identifier": "robot2/cmd_vel", "linear": 0.2, "angular": 0.1},
        {"identifier": "robot3/stream", "camera": "front", "fps": 5},
        {"identifier": "robot1/lease", "force": True},
    ]
    frames: list[str | bytes] = []
    for i in range(count):
        message = dict(rng.choice(valid))
        message["id"] = f"z{i}"
        kind = rng.randrange(10)
        field = rng.choice([k for k in message if k not in ("identifier", "id")])
        if kind == 0:
            message[field] = rng.choice(["1", None, [], {}, True, "NaN"])  # wrong type
            frames.append(json.dumps(message))
        elif kind == 1:
            text = json.dumps({**message, field: 12345.5})
            frames.append(text.replace("12345.5", rng.choice(["NaN", "Infinity", "-Infinity", "1e999", "-1e400"])))
        elif kind == 2:
            message[field] = rng.choice([1e300, -1e300, 2**80])  # huge
            if message["identifier"].endswith("cmd_vel"):
                message[field] = "fast"  # clamped speeds are legal; make it wrong instead
            frames.append(json.dumps(message))
        elif kind == 3:
            frames.append(json.dumps({**message, "nest": json.loads("[" * 30 + "]" * 30)}))
        elif kind == 4:
            message["identifier"] = rng.choice(["robot1/teleport", "robot9/goal_pose", "launch", "", 7])
            frames.append(json.dumps(message))
        elif kind == 5:
            frames.append(json.dumps({**message, "pad": "x" * rng.randrange(70_000, 200_000)}))
        elif kind == 6:
            frames.append(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 64))))  # binary
        elif kind == 7:
            text = json.dumps(message)
            frames.append(text[: rng.randrange(1, len(text) - 1)])  # truncated JSON
        elif kind == 8:
            required = {"goal_pose": "x", "cmd_vel": "angular", "stream": "fps"}
            kind_name = message["identifier"].split("/")[1]
            if kind_name in required:
                del message[required[kind_name]]  # a required field missing
            else:
                message["action"] = "steal"  # lease: an action that does not exist
            frames.append(json.dumps(message))
        else:
            frames.append(rng.choice(["[1,2]", '"text"', "null", "{}", "{'single': 'quotes'}"]))
    return frames
