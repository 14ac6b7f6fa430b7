"""The ``bag`` backend: rosbag2 recordings (sqlite3 or MCAP) replayed with ``rosbags``; no ROS needed.

**Which robot a bag plays as.** ``--bag ROBOT=PATH`` binds a bag to a robot of robots.yaml. An unbound bag
plays as every robot whose own namespaced topics it contains (``/robot1/odom``: a recording of the fleet, as
``xr-relay record`` makes); a bag of un-namespaced topics (``/odom``, ``/scan``, ``/tf``) plays as the first
robot not yet bound. A robot's configured topics are looked up in its bag as written, then without the robot's
namespace (``/robot1/odom`` -> ``/odom``), so single-robot bags play with the default robots.yaml. The pose
topic must be in the bag with the expected type; the scan, sensors and cameras it lacks are left out. Robots
bound to no bag stay offline, and no robot can be commanded (:meth:`BagBackend.command_refusal`).

**Timing.** All bags start together at position 0 (each at its own first message) and keep their recorded
timing scaled by the rate, on the event loop's clock (:class:`PlaybackClock`). Pause, resume, seek and rate
come from clients (``playback/...``); a ``PlaybackEvent`` reports the position once a second and on every
change. At the end, playback starts over with ``--loop`` and otherwise stays paused at the end. Stamps are
the messages' own (header stamps, else the time they were recorded), as a live robot would have sent them.

**Threads.** Each bag has one reader thread (:class:`_BagReader`) that owns its rosbags reader: it decodes the
messages its robots need, in time order, turns them into immutable events (poses, composed from TF when the
pose source is ``tf``; decimated scans; sensor values; maps) and appends them to a bounded buffer ahead of
the playback position; a bag is never read into memory whole. On the loop, one task per bag pops events from
that buffer when the clock reaches them (the lock is held for microseconds) and hands them to the relay.
Camera images cross the same buffer as decoded messages and are converted to JPEG (relay.media.imaging) in a small
worker pool, only when a client streams or snapshots that camera.
"""

from .backend import BagBackend
from .binding import BagContents, BagPlan, BagSpec, RobotTopics, bind_bags, parse_bag_specs
from .clock import PlaybackClock

__all__ = [
    "BagBackend",
    "BagContents",
    "BagPlan",
    "BagSpec",
    "PlaybackClock",
    "RobotTopics",
    "bind_bags",
    "parse_bag_specs",
]
