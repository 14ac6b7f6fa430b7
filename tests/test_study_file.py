"""The study file (issue #34): a study read whole, every mistake named by line and field, the conditions' order
counterbalanced by a balanced Latin square, and the questionnaires scored by their standard formulas."""

from __future__ import annotations

import itertools
from collections import Counter

import pytest

from relay.errors import ConfigError
from relay.study.counterbalance import latin_orders, williams
from relay.study.model import FindingAtTarget, GoalReached, RobotInRegion
from relay.study.scores import AnswerError, sus_score, tlx_raw
from relay.study.study_file import parse_study
from tests.helpers.study_files import VALVE_STUDY


def test_a_study_is_read_whole() -> None:
    study = parse_study(VALVE_STUDY)
    assert study.name == "valve-and-spill"
    assert study.participants == ("P01", "P02", "P03", "P04")
    assert [c.name for c in study.conditions] == ["headset", "desktop"]
    assert study.conditions[1].client == (("view", "desktop"), ("sound", "off"))  # YAML's bare off: the setting
    # Two conditions: the Latin square alternates them.
    assert [study.order(p) for p in study.participants] == [("headset", "desktop"), ("desktop", "headset")] * 2
    reach, mark, park = study.tasks
    assert reach.time_limit == 180 and reach.start.poses[0].robot == "robot1" and reach.start.reset_estop
    assert isinstance(reach.success, RobotInRegion) and reach.success.region[2] == (12.0, 4.0)
    assert reach.probes[0].question == "room" and reach.probes[0].at == 30
    assert mark.success == FindingAtTarget("spill") and mark.start.poses == ()
    assert park.success == GoalReached("robot2", without_collision=True)
    assert study.after_task == ("tlx",) and study.after_condition == ("sus",)


def test_an_order_may_be_given() -> None:
    text = VALVE_STUDY.replace(
        "questionnaires:",
        "order: {P01: [desktop, headset], P02: [desktop, headset], P03: [headset, desktop], P04: [headset, desktop]}\n"
        "questionnaires:",
    )
    assert parse_study(text).order("P02") == ("desktop", "headset")


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (
            ("time_limit: 180", "time_limit: soon"),
            'study.yaml:10: tasks[0].time_limit: expected a positive number, got "soon"',
        ),
        (
            ("view: headset", "view: goggles"),
            'study.yaml:4: conditions[0].client.view: expected one of desktop, headset, got "goggles"',
        ),
        (
            ("question: room", "question: mood"),
            'study.yaml:13: tasks[0].probes[0].question: expected one of room, mode, nearest_robot, got "mood"',
        ),
        (("at: 30", "at: 300"), "study.yaml:13: tasks[0].probes[0].at: after the task's time limit (180 s)"),
        (
            ("[12, 4], [9, 4]", "[12, 4], [9]"),
            "study.yaml:12: tasks[0].success.robot_in_region.region[3]: expected [x, y] in metres, got a list",
        ),
        (("[P01, P02, P03, P04]", "[P01, P02, P01]"), 'study.yaml:2: participants[2]: "P01" appears twice'),
        (
            ("    time_limit: 120\n", "    time_limt: 120\n"),
            "study.yaml:16: tasks[1].time_limt: unknown field; expected one of name, instruction, time_limit, start, "
            "success, probes",
        ),
        (("name: park", "name: mark-spill"), 'study.yaml:18: tasks[2].name: "mark-spill" appears twice'),
        (
            ("{finding_at_target: {target: spill}}", "{}"),
            "study.yaml:17: tasks[1].success: expected exactly one of robot_in_region, finding_at_target, goal_reached",
        ),
    ],
)
def test_a_mistake_is_named_by_line_and_field(change: tuple[str, str], where: str) -> None:
    text = VALVE_STUDY.replace(*change)
    assert text != VALVE_STUDY
    with pytest.raises(ConfigError) as raised:
        parse_study(text)
    assert str(raised.value) == where


def test_a_given_order_names_what_is_wrong() -> None:
    missing = VALVE_STUDY.replace(
        "questionnaires:", "order: {P01: [desktop], P02: [desktop, headset]}\nquestionnaires:"
    )
    with pytest.raises(ConfigError, match=r"study.yaml:6: order.P03: is required"):
        parse_study(missing)
    orders = "P02: [desktop, headset], P03: [headset, desktop], P04: [headset, desktop]"
    with pytest.raises(ConfigError, match=r"study.yaml:6: order.P01: every condition once; missing headset"):
        parse_study(VALVE_STUDY.replace("questionnaires:", f"order: {{P01: [desktop], {orders}}}\nquestionnaires:"))
    with pytest.raises(ConfigError, match=r'order.P01: "vr" is not a condition; expected one of headset, desktop'):
        parse_study(VALVE_STUDY.replace("questionnaires:", f"order: {{P01: [vr, desktop], {orders}}}\nquestionnaires:"))


def test_bad_yaml_and_an_empty_file_are_named() -> None:
    with pytest.raises(ConfigError, match=r"^study.yaml:2: not valid YAML"):
        parse_study("study: x\n  participants: [")
    with pytest.raises(ConfigError, match="the file is empty"):
        parse_study("")


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_the_latin_square_is_balanced(n: int) -> None:
    rows = williams(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:
        assert sorted(row) == list(range(n)), "every condition once in a row"
    for position in range(n):
        counts = Counter(row[position] for row in rows)
        assert set(counts.values()) == {len(rows) // n}, "every condition equally often at every position"
    if n > 1:
        follows = Counter((a, b) for row in rows for a, b in itertools.pairwise(row))
        assert set(follows) == {(a, b) for a in range(n) for b in range(n) if a != b}
        assert len(set(follows.values())) == 1, "every condition follows every other equally often"


def test_participants_take_the_rows_in_turn() -> None:
    orders = latin_orders(["A", "B", "C", "D", "E"], ["x", "y", "z", "w"])
    assert orders[0] == ("A", ("x", "y", "w", "z"))
    assert orders[4][1] == orders[0][1], "the fifth participant starts the square again"


def test_sus_and_tlx_are_scored_by_their_formulas() -> None:
    # By hand: odd items give answer - 1, even items 5 - answer, the sum times 2.5.
    assert sus_score([5, 1, 5, 1, 5, 1, 5, 1, 5, 1]) == 100.0
    assert sus_score([1, 5, 1, 5, 1, 5, 1, 5, 1, 5]) == 0.0
    assert sus_score([3] * 10) == 50.0
    # 4-1 + 5-2 + 5-1 + 5-3 + 3-1 + 5-2 + 4-1 + 5-1 + 4-1 + 5-2 = 3+3+4+2+2+3+3+4+3+3 = 30 -> 75
    assert sus_score([4, 2, 5, 3, 3, 2, 4, 1, 4, 2]) == 75.0
    assert tlx_raw([70, 10, 40, 25, 55, 30]) == pytest.approx(230 / 6)
    with pytest.raises(AnswerError, match="SUS item 3: expected 1-5, got 6"):
        sus_score([3, 3, 6, 3, 3, 3, 3, 3, 3, 3])
    with pytest.raises(AnswerError, match="SUS has 10 items, got 9 answers"):
        sus_score([3] * 9)
    with pytest.raises(AnswerError, match="NASA-TLX frustration: expected 0-100, got 101"):
        tlx_raw([0, 0, 0, 0, 0, 101])
