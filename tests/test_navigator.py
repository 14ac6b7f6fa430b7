"""The fake Nav2 navigator's rules (relay/sim/navigator.py) without I/O: statuses, cancel as rcl_action answers it,
Nav2's error codes, the controller's output and feedback, on the sim's own grid, with a clock moved by hand. The
robot is moved here from the controller's output, as a watchdog that forwards everything would move it."""

from __future__ import annotations

import math
import textwrap

from relay.config import parse_config
from relay.fleet.occupancy import OccupancyGrid
from relay.sim import navigator as nav
from relay.sim.navigator import Navigator, world_planner
from relay.sim.planner import Planner
from relay.sim.world import PLANNING_RADIUS, SimWorld

FLEET = textwrap.dedent(
    """\
    robots:
      - name: alpha
        limits: {linear: 0.6, angular: 1.8}
        initial_pose: {x: 3.0, y: 1.5, yaw: 0.0}
      - name: beta
        limits: {linear: 0.6, angular: 1.8}
        initial_pose: {x: 9.0, y: 1.5, yaw: 0.0}
    """
)
T0 = 1_700_000_000.0


def uuid(n: int) -> bytes:
    return bytes([n]) * 16


def navigator(world: SimWorld, *, misbehave: bool = False) -> Navigator:
    limits = world.robots["alpha"].limits
    return Navigator(world_planner(world, "alpha"), limits, misbehave_after_cancel=misbehave)


def run(world: SimWorld, navigation: Navigator, start: float, seconds: float, *, drive: bool = True) -> list[nav.Tick]:
    """Ticks at 20 Hz for ``seconds``; each command moves alpha (when ``drive``) as a 50 Hz base would."""
    ticks = []
    for i in range(round(seconds / nav.PERIOD)):
        tick = navigation.step(world.robots["alpha"].state, start + i * nav.PERIOD)
        ticks.append(tick)
        if drive and tick.command is not None:
            world.set_velocity("alpha", *tick.command)
        for _ in range(2):
            world.step(nav.PERIOD / 2)
    return ticks


def test_a_goal_is_accepted_executed_with_feedback_and_succeeds_with_one_zero() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    goal = navigation.goal(uuid(1), 6.0, 1.5, 0.0, T0)
    assert goal.status == nav.ACCEPTED and goal.stamp == round(T0 * 1e9)
    first = navigation.step(world.robots["alpha"].state, T0 + 0.05)
    assert first.status_changed and goal.status == nav.EXECUTING and first.command is None
    ticks = run(world, navigation, T0 + 0.1, 15.0)
    assert goal.status == nav.SUCCEEDED and (goal.error_code, goal.error_msg) == (0, "")
    end = next(i for i, t in enumerate(ticks) if t.status_changed)
    driving = ticks[:end]
    assert all(t.command is not None for t in driving), "the controller publishes every tick while it executes"
    assert ticks[end].command == (0.0, 0.0) and all(t.command is None for t in ticks[end + 1 :])
    state = world.robots["alpha"].state
    assert math.hypot(state.x - 6.0, state.y - 1.5) <= 0.1
    feedback = [t.feedback for t in driving if t.feedback is not None]
    assert abs(feedback[0].distance_remaining - 3.0) < 0.05
    remaining = [f.distance_remaining for f in feedback]
    assert remaining == sorted(remaining, reverse=True) and remaining[-1] < 0.15
    assert feedback[-1].navigation_time > feedback[0].navigation_time > 0
    cruising = next(f for f in feedback if f.distance_remaining < 2.0)  # at 0.6 m/s: 2 m is ~3.3 s away
    assert abs(cruising.estimated_time_remaining - cruising.distance_remaining / 0.6) < 0.5
    assert all(f.uuid == uuid(1) and f.number_of_recoveries == 0 for f in feedback)


def test_unplannable_goals_are_aborted_with_nav2s_error_codes() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    # A closed room east of the corridor: free inside, walled all round (NO_VALID_PATH, not GOAL_OCCUPIED).
    occupied = world.grid.occupied.copy()
    r = world.grid.resolution
    rows, cols = slice(round(4.0 / r), round(7.0 / r)), slice(round(12.0 / r), round(15.0 / r))
    occupied[rows, cols] = True
    occupied[round(4.3 / r) : round(6.7 / r), round(12.3 / r) : round(14.7 / r)] = False
    grid = OccupancyGrid(world.grid.origin_x, world.grid.origin_y, r, occupied)
    world.grid, world.planner = grid, Planner(grid, PLANNING_RADIUS)
    cases = [
        ((30.0, 5.0), nav.GOAL_OUTSIDE_MAP, "outside the map"),
        ((12.02, 5.5), nav.GOAL_OCCUPIED, "inside an obstacle"),
        ((9.2, 1.5), nav.GOAL_OCCUPIED, "next to beta"),
        ((13.5, 5.5), nav.NO_VALID_PATH, "not reachable"),
    ]
    for n, ((x, y), code, why) in enumerate(cases):
        navigation = navigator(world)
        goal = navigation.goal(uuid(n), x, y, None, T0)
        navigation.step(world.robots["alpha"].state, T0 + 0.05)
        tick = navigation.step(world.robots["alpha"].state, T0 + 0.1)
        assert tick.status_changed and goal.status == nav.ABORTED, (x, y)
        assert goal.error_code == code and why in goal.error_msg, (goal.error_code, goal.error_msg)
        assert tick.command is None, "a goal that never moved the robot gets no zero either"


def test_a_new_goal_preempts_the_running_one_which_nav2_reports_aborted() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    first = navigation.goal(uuid(1), 6.0, 1.5, None, T0)
    ticks = run(world, navigation, T0 + 0.05, 1.0)
    second = navigation.goal(uuid(2), 3.0, 4.0, None, T0 + 1.05)
    assert (first.status, first.error_code, first.error_msg) == (nav.ABORTED, 0, "")
    ticks = run(world, navigation, T0 + 1.1, 0.2)
    assert second.status == nav.EXECUTING and ticks[-1].command is not None
    assert [g.uuid for g in navigation.goals] == [uuid(1), uuid(2)]


def test_cancel_follows_rcl_action_and_the_controller_stops_with_one_zero() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    goal = navigation.goal(uuid(1), 6.0, 1.5, None, T0)
    run(world, navigation, T0 + 0.05, 1.0)
    assert navigation.cancel(uuid(9), 0, T0 + 1.05) == (nav.ERROR_UNKNOWN_GOAL_ID, [])
    assert navigation.cancel(uuid(1), 0, T0 + 1.05) == (nav.ERROR_NONE, [goal])
    assert goal.status == nav.CANCELING
    ticks = run(world, navigation, T0 + 1.1, 0.5)
    assert goal.status == nav.CANCELED and ticks[0].status_changed
    assert ticks[0].command == (0.0, 0.0) and all(t.command is None for t in ticks[1:])
    assert navigation.cancel(uuid(1), 0, T0 + 2.0) == (nav.ERROR_GOAL_TERMINATED, [])
    assert navigation.cancel(bytes(16), 0, T0 + 2.0) == (nav.ERROR_NONE, []), "nothing left to cancel: no error"


def test_cancel_all_and_cancel_by_stamp() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    for n in (1, 2, 3):  # each preempts the one before: only the last is active
        navigation.goal(uuid(n), 6.0, 1.5, None, T0 + n)
    code, goals = navigation.cancel(bytes(16), nav.stamp_ns(T0 + 2), T0 + 4)
    assert (code, goals) == (nav.ERROR_NONE, []), "goals accepted at or before the stamp: none still active"
    code, goals = navigation.cancel(bytes(16), nav.stamp_ns(T0 + 3), T0 + 4)
    assert code == nav.ERROR_NONE and [g.uuid for g in goals] == [uuid(3)]
    navigation.goal(uuid(4), 6.0, 1.5, None, T0 + 5)
    code, goals = navigation.cancel(bytes(16), 0, T0 + 6)
    assert code == nav.ERROR_NONE and [g.uuid for g in goals] == [uuid(4)]


def test_a_misbehaving_controller_keeps_driving_after_a_cancel() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world, misbehave=True)
    goal = navigation.goal(uuid(1), 8.0, 1.5, None, T0)
    run(world, navigation, T0 + 0.05, 1.0)
    navigation.cancel(uuid(1), 0, T0 + 1.05)
    ticks = run(world, navigation, T0 + 1.1, 2.0)
    assert goal.status == nav.CANCELED
    assert all(t.command is not None and t.command[0] > 0.1 for t in ticks[5:]), "it drives on, cancelled"
    navigation.goal(uuid(2), 3.0, 1.5, None, T0 + 3.1)  # a new goal ends the rogue output
    assert run(world, navigation, T0 + 3.15, 0.05)[0].command is None


def test_a_robot_that_makes_no_progress_for_10_s_aborts_its_goal() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    goal = navigation.goal(uuid(1), 6.0, 1.5, None, T0)
    ticks = run(world, navigation, T0 + 0.05, 10.0, drive=False)  # the gate holds it: the base gets nothing
    assert goal.status == nav.EXECUTING and all(t.command is not None for t in ticks[1:])
    ticks = run(world, navigation, T0 + 10.05, 0.5, drive=False)
    assert goal.status == nav.ABORTED and goal.error_code == nav.FAILED_TO_MAKE_PROGRESS
    assert "moved less than 0.5 m in 10 s" in goal.error_msg


def test_ended_goals_leave_the_status_list_after_the_result_timeout_or_beyond_16() -> None:
    world = SimWorld(parse_config(FLEET), lambda *_: None)
    navigation = navigator(world)
    for n in range(20):
        navigation.goal(uuid(n), 30.0, 1.5, None, T0 + n)  # outside the map: each aborts at once
        navigation.step(world.robots["alpha"].state, T0 + n + 0.05)
        navigation.step(world.robots["alpha"].state, T0 + n + 0.1)
    assert [g.uuid for g in navigation.goals] == [uuid(n) for n in range(4, 20)]
    assert navigation.result(uuid(19)) is not None and navigation.result(uuid(0)) is None
    tick = navigation.step(world.robots["alpha"].state, T0 + 19.1 + nav.RESULT_TIMEOUT + 1)
    assert tick.status_changed and navigation.goals == []
