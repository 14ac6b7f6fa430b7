"""The ros backend's executor thread: one rclpy executor spun from a thread of its own, stopped from any other.

rclpy is not imported here until a Spinner is made (the backend passes its executors module in).

**The executor.** rclpy's EventsExecutor dispatches from C++ and reaches 3.5x the SingleThreadedExecutor's
rate on raw Odometry (bench/bench_ros_ingest.py: 8.1k vs 2.35k a second). In this rclpy (9.1.2, PyPI wheels)
its ``spin()`` dispatches nothing from a thread other than the main one and its ``shutdown()`` then blocks for
ever; ``spin_until_future_complete`` works from a thread, subscriptions made and destroyed while it spins work
(bench/ros_sub.py checks both every run; tests/test_ros_ingest.py creates and destroys subscriptions while
spinning and stops it), so :class:`Spinner` spins it that way, until a future it owns is done.
``ros.executor: single`` in robots.yaml keeps the SingleThreadedExecutor.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable
from importlib import import_module
from typing import Any

logger = logging.getLogger(__name__)


class Spinner:
    """One executor on one thread, stopped from any other: EventsExecutor (default) or SingleThreadedExecutor."""

    def __init__(self, executors: Any, context: Any, kind: str, on_failure: Callable[[str], None]) -> None:
        self.kind = kind
        self._context = context
        self._on_failure = on_failure
        # rclpy's Future: the EventsExecutor waits on its done callback (with concurrent.futures' Future it
        # dispatched some callbacks and missed most: 426 of 1000 Odometry a second, bench/bench_ros_ingest.py).
        self._stop: Any = import_module("rclpy.task").Future()
        self.executor = self._create(executors, context, kind)
        self._thread: threading.Thread | None = None

    @staticmethod
    def _create(executors: Any, context: Any, kind: str) -> Any:
        if kind == "events":
            try:
                events = import_module("rclpy.experimental.events_executor")
                return events.EventsExecutor(context=context)
            except (ImportError, AttributeError) as exc:  # an rclpy before Jazzy has none
                logger.warning("no EventsExecutor in this rclpy (%s): using the SingleThreadedExecutor", exc)
        return executors.SingleThreadedExecutor(context=context)

    def start(self, node: Any) -> None:
        self.executor.add_node(node)
        self._thread = threading.Thread(target=self._spin, name="ros-executor", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            if self.kind == "events":
                while not self._stop.done() and self._context.ok():
                    self.executor.spin_until_future_complete(self._stop, timeout_sec=1.0)
            else:
                self.executor.spin()
        except Exception as exc:  # the context was shut down under it, or rclpy failed
            if not self._stop.done():
                logger.exception("ROS executor stopped: %s", exc)
                self._on_failure(f"the ROS executor stopped: {exc}")
            return
        if not self._stop.done():
            # spin returned although nobody stopped us: the executor was shut down under the relay.
            self._on_failure("the ROS executor stopped")

    def stop(self, timeout: float = 2.0) -> None:
        """Blocking (a worker thread): end the spin, then shut the executor down. Never waits more than
        ``timeout`` for the thread; the EventsExecutor is shut down only once its thread has left it."""
        if not self._stop.done():
            self._stop.set_result(None)
        thread = self._thread
        if self.kind == "events":
            with contextlib.suppress(Exception):
                self.executor.wake()
            if thread is not None:
                thread.join(timeout)
            if thread is not None and thread.is_alive():
                logger.error("the ROS executor thread did not stop within %.1f s; left to the process's exit", timeout)
                return
            self.executor.shutdown(timeout_sec=1.0)
        else:
            self.executor.shutdown(timeout_sec=1.0)
            if thread is not None:
                thread.join(timeout)
