"""A small Nav2-shaped navigator the DDS tests run in their own process: what the relay's ros backend must speak.

    python tests/nav2_peer.py CONFIG.json

Per robot namespace of the JSON's ``robots``: it takes goals on ``<ns>/goal_pose`` (as Nav2's bt_navigator does),
lists each as a NavigateToPose goal with an id of its own on ``<ns>/navigate_to_pose/_action/status``
(action_msgs/GoalStatusArray, reliable, transient local, depth 1: rcl_action's QoS), preempts the goal running
(ABORTED, as Nav2 does), and ends it: a goal at x < 0 is ABORTED 0.3 s after it started (unreachable), one at
x >= 50 runs until cancelled, any other SUCCEEDS after ``duration`` seconds. It serves action_msgs/CancelGoal on
``<ns>/navigate_to_pose/_action/cancel_goal`` (unless ``serve_cancel`` is false), cancelling every running goal for
a zero id and stamp. With ``gate_state`` set, it publishes that word on ``<ns>/xr_relay/gate_state`` (transient local)
as a watchdog would, and it prints every word received on ``<ns>/xr_relay/gate``.

Everything it does is printed as one JSON line with the time on the shared monotonic clock.
"""

from __future__ import annotations

import json
import sys
import time
import uuid
from typing import Any

import rclpy
from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from geometry_msgs.msg import PoseStamped
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

NAMES = {1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}
ACTIVE = (GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING)


def emit(record: dict[str, Any]) -> None:
    print(json.dumps({**record, "t": time.monotonic()}), flush=True)  # noqa: T201 - the test reads these lines


class Navigator:
    def __init__(self, node: Any, ns: str, spec: dict[str, Any]) -> None:
        self.node, self.ns = node, ns
        self.duration = float(spec.get("duration", 0.5))
        self.goals: list[dict[str, Any]] = []  # id, stamp, status, ends (monotonic), fate
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.status_pub = node.create_publisher(GoalStatusArray, f"{ns}/navigate_to_pose/_action/status", latched)
        node.create_subscription(
            PoseStamped, f"{ns}/goal_pose", self.on_goal, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        )
        if spec.get("serve_cancel", True):
            node.create_service(CancelGoal, f"{ns}/navigate_to_pose/_action/cancel_goal", self.on_cancel)
        node.create_subscription(String, f"{ns}/xr_relay/gate", lambda m: emit({"robot": ns, "gate": m.data}), latched)
        if spec.get("gate_state") is not None:
            self.gate_state = node.create_publisher(String, f"{ns}/xr_relay/gate_state", latched)
            self.gate_state.publish(String(data=spec["gate_state"]))

    def publish(self) -> None:
        array = GoalStatusArray()
        for goal in self.goals[-10:]:
            info = GoalInfo()
            info.goal_id.uuid = list(goal["id"])
            info.stamp = goal["stamp"]
            array.status_list.append(GoalStatus(goal_info=info, status=goal["status"]))
        self.status_pub.publish(array)

    def set(self, goal: dict[str, Any], status: int) -> None:
        goal["status"] = status
        emit({"robot": self.ns, "status": NAMES[status], "x": goal["x"], "id": goal["id"].hex()})

    def on_goal(self, message: PoseStamped) -> None:
        x, y = message.pose.position.x, message.pose.position.y
        emit({"robot": self.ns, "goal": [x, y]})
        for goal in self.goals:
            if goal["status"] in ACTIVE:
                self.set(goal, GoalStatus.STATUS_ABORTED)  # preempted, as Nav2's navigator does
        fate = "abort" if x < 0 else "run" if x >= 50 else "succeed"
        ends = time.monotonic() + (0.3 if fate == "abort" else self.duration)
        goal = {"id": uuid.uuid4().bytes, "stamp": self.node.get_clock().now().to_msg(), "x": x, "ends": ends,
                "fate": fate}  # fmt: skip
        self.goals.append(goal)
        self.set(goal, GoalStatus.STATUS_ACCEPTED)
        self.publish()
        self.set(goal, GoalStatus.STATUS_EXECUTING)
        self.publish()

    def on_cancel(self, request: Any, response: Any) -> Any:
        everything = bytes(request.goal_info.goal_id.uuid) == bytes(16)
        emit({"robot": self.ns, "cancel": "all" if everything else bytes(request.goal_info.goal_id.uuid).hex()})
        for goal in self.goals:
            if goal["status"] in ACTIVE and (everything or goal["id"] == bytes(request.goal_info.goal_id.uuid)):
                info = GoalInfo()
                info.goal_id.uuid = list(goal["id"])
                info.stamp = goal["stamp"]
                response.goals_canceling.append(info)
                self.set(goal, GoalStatus.STATUS_CANCELED)
        response.return_code = CancelGoal.Response.ERROR_NONE if response.goals_canceling else 1  # ERROR_REJECTED
        self.publish()
        return response

    def tick(self) -> None:
        now = time.monotonic()
        for goal in self.goals:
            if goal["status"] == GoalStatus.STATUS_EXECUTING and goal["fate"] != "run" and now >= goal["ends"]:
                done = GoalStatus.STATUS_ABORTED if goal["fate"] == "abort" else GoalStatus.STATUS_SUCCEEDED
                self.set(goal, done)
                self.publish()


def main() -> int:
    spec = json.loads(open(sys.argv[1]).read())  # noqa: SIM115
    rclpy.init()
    node = rclpy.create_node("nav2_peer")
    navigators = [Navigator(node, robot["ns"], robot) for robot in spec["robots"]]

    def tick() -> None:
        for navigator in navigators:
            navigator.tick()

    node.create_timer(0.02, tick)
    emit({"ready": True})
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
