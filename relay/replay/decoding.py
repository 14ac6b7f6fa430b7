"""A recorded session's messages back to the fleet's events, without I/O (the reader thread applies it).

A session recording (relay/replay/recorder.py) holds what the relay sent, as the wire's JSON, on ``/out/<identifier>``
channels, and what clients sent on ``/in/<client id>``. The robots' state comes back as the events a backend reports:
``<robot>/pose`` as a PoseEvent with the recorded stamp, ``<robot>/sensor`` a SensorEvent, ``<robot>/nav`` a NavEvent,
``<robot>/path`` a PathEvent; the relay then builds the same messages again (equal to the record: positions are
rounded to 0.1 mm both times). A client's ``viewer`` frames (relay/wire/viewer.py: where its operator looked from)
come back as AvatarEvents, named as the recording's ``operators`` named the client. Everything else (answers, estops,
leases, the commands clients sent) is not replayed: nothing of it may reach a robot, and the page of a replay shows
the robots as they were.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from typing import Any, Final

import orjson

from ..errors import ProtocolError
from ..fleet.events import AvatarEvent, Event, NavEvent, PathEvent, PoseEvent, SensorEvent
from ..wire.declare import Frame
from ..wire.viewer import Viewer

#: The prefix of the channels of what the relay sent (``/out/robot1/pose``) and was sent (``/in/c3-ab12cd``).
OUT: Final = "/out/"
IN: Final = "/in/"
#: The robot-scoped kinds a replay plays, as events.
PLAYED_KINDS: Final = ("pose", "sensor", "nav", "path")
#: The schema name every channel of a session recording carries.
SCHEMA_NAME: Final = "xr_relay.Message"

Key = tuple[str, ...]


class NotAMessage(ValueError):
    """A recorded message that is not what its channel carries (a hand-edited or foreign file)."""


def played_topics(topics: Collection[str], robots: Collection[str]) -> list[str]:
    """The channels a replay of ``robots`` reads, among a recording's: theirs, and what every client sent."""
    wanted = {f"{OUT}{robot}/{kind}" for robot in robots for kind in PLAYED_KINDS}
    return sorted(t for t in topics if t in wanted or t.startswith(IN))


def operator_names(data: bytes, names: dict[str, str]) -> None:
    """Add the names an ``operators`` message gives (client id -> name) to ``names``."""
    obj = orjson.loads(data)
    given = obj.get("names") if isinstance(obj, dict) else None
    if isinstance(given, dict):
        names.update((k, v) for k, v in given.items() if isinstance(k, str) and isinstance(v, str))


def recorded_robots(topics: Collection[str]) -> set[str]:
    """The robots whose poses a recording holds (``/out/<robot>/pose``)."""
    poses = (t for t in topics if t.startswith(OUT) and t.endswith("/pose") and t.count("/") == 3)
    return {t[len(OUT) : -len("/pose")] for t in poses}


def _number(obj: dict[str, Any], key: str) -> float:
    value = obj[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise NotAMessage(f"field {key!r} is not a finite number")
    return float(value)


def _avatar(client: str, data: bytes, stamp: float, names: Mapping[str, str]) -> tuple[Key, Event] | None:
    """A client's recorded frame, when it was a valid ``viewer``: its operator's avatar at ``stamp``."""
    try:
        frame = orjson.loads(orjson.loads(data)["frame"])
        if not isinstance(frame, dict) or frame.get("identifier") != "viewer":
            return None
        viewer = Viewer.parse(frame, Frame("viewer", None, ()))
    except (orjson.JSONDecodeError, KeyError, TypeError, ProtocolError):
        return None  # not a viewer, or one the relay refused when it came
    return ("avatar", client), AvatarEvent(client, names.get(client), stamp, viewer.head, viewer.hands)


def decode(topic: str, data: bytes, stamp: float, names: Mapping[str, str]) -> tuple[Key, Event] | None:
    """The event a recorded message of ``topic`` stands for, and the key of the state it holds (the latest per key is
    the state at a seek's target); None for a message a replay does not play. ``stamp``: when the relay recorded it
    (s since the epoch); ``names``: the recording's operators by client id. Raises NotAMessage."""
    if topic.startswith(IN):
        return _avatar(topic[len(IN) :], data, stamp, names)
    if not topic.startswith(OUT):
        return None
    robot, _, kind = topic[len(OUT) :].partition("/")
    try:
        obj = orjson.loads(data)
        if not isinstance(obj, dict):
            raise NotAMessage("not a JSON object")
        if kind == "pose":
            pose = PoseEvent(
                robot, _number(obj, "stamp"), str(obj["frame"]),
                *(_number(obj, k) for k in ("x", "y", "z", "qx", "qy", "qz", "qw")),
            )  # fmt: skip
            return ("pose", robot), pose
        if kind == "sensor":
            name = str(obj["name"])
            return ("sensor", robot, name), SensorEvent(robot, name, _number(obj, "value"), _number(obj, "stamp"))
        if kind == "nav":
            goal = obj["goal"]
            target = None if goal is None else (_number(goal, "x"), _number(goal, "y"), goal.get("yaw"))
            outcome = obj["outcome"]
            if outcome not in ("started", "reached", "failed", "cancelled"):
                raise NotAMessage(f"unknown outcome {outcome!r}")
            nav = NavEvent(robot, outcome == "started", target, outcome, str(obj.get("message") or ""))
            return ("nav", robot), nav
        if kind == "path":
            points = tuple((float(x), float(y)) for x, y in obj["points"])
            return ("path", robot), PathEvent(robot, points)
    except (orjson.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise NotAMessage(f"{topic}: {exc}") from None
    return None
