"""A reading's trend over a target's last rounds (relay/inspection/trend.py) and the ``changed`` finding it makes when
it heads for its limit (relay/inspection/change_watch.py).

The rule is checked on constructed readings whose line is worked out by hand; the finding on a real store (SQLite)
fed three rounds of the simulator's own gas readings, a minute apart, as its spill grows."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from relay.config import load_config
from relay.inspection.change_watch import ChangeWatch
from relay.inspection.records import CaptureRecord, ReadingTrend
from relay.inspection.report_rows import Limit
from relay.inspection.sparkline import SPARK_BOX, Box, label_y, polyline, sparkline
from relay.inspection.store import Store
from relay.inspection.trend import HORIZON_ROUNDS, TREND_ROUNDS, Point, concern, fit, series_of, trend_of
from relay.sim.world import SimWorld
from tests.conftest import ROOT

GAS = Limit("ppm", warn_above=400.0)


def points(*values: float, every: float = 60.0) -> list[Point]:
    return [Point(1795388500.0 + every * i, v, f"m-{i}") for i, v in enumerate(values)]


def test_a_reading_rising_toward_its_limit_trends_toward_it() -> None:
    # 200, 280, 360 a minute apart: the line rises 80 ppm a round and is at 360 now, 40 ppm short: half a round.
    trend = trend_of("gas", points(200.0, 280.0, 360.0), GAS)
    assert trend.slope == pytest.approx(80.0) and trend.rounds_left == pytest.approx(0.5)
    assert trend.toward_limit and (trend.limit, trend.side) == (400.0, "above")
    assert trend.words() == (
        "gas 200.0, 280.0, 360.0 ppm over the last 3 rounds (+80.0 ppm a round): "
        "at that rate over its 400 ppm limit within 1 round"
    )
    # Uneven rounds, 0, 60 and 180 s at 200, 250, 350 ppm: means 80 s and 266.67 ppm, sum dt.dv = 14000 over
    # sum dt^2 = 16800: 0.8333 ppm/s; a round is the median gap, 90 s: 75 ppm a round. The line at 180 s is
    # 266.67 + 0.8333 * 100 = 350 ppm, 50 short: 0.67 rounds.
    uneven = trend_of("gas", [Point(0.0, 200.0, "a"), Point(60.0, 250.0, "b"), Point(180.0, 350.0, "c")], GAS)
    assert uneven.slope == pytest.approx(75.0) and uneven.rounds_left == pytest.approx(2 / 3)
    assert uneven.toward_limit


def test_flat_falling_slow_or_too_few_readings_do_not() -> None:
    flat = trend_of("gas", points(300.0, 300.0, 300.0), GAS)
    assert flat.slope == 0.0 and flat.rounds_left is None and not flat.toward_limit
    falling = trend_of("gas", points(360.0, 280.0, 200.0), GAS)
    assert falling.slope == pytest.approx(-80.0) and not falling.toward_limit
    # Rising 10 ppm a round from 120 ppm: 28 rounds away, beyond the horizon.
    slow = trend_of("gas", points(100.0, 110.0, 120.0), GAS)
    assert slow.rounds_left == pytest.approx(28.0) and HORIZON_ROUNDS < 28 and not slow.toward_limit
    two = trend_of("gas", points(200.0, 380.0), GAS)
    assert two.slope is None and not two.toward_limit
    assert trend_of("gas", [], GAS).slope is None
    # Readings at one instant have no slope.
    assert fit([Point(5.0, 1.0, None), Point(5.0, 2.0, None), Point(5.0, 3.0, None)]) is None


def test_a_reading_already_past_its_limit_is_the_threshold_rules_not_a_trend() -> None:
    above = trend_of("gas", points(380.0, 400.0, 420.0), GAS)
    assert above.slope == pytest.approx(20.0) and above.rounds_left == 0.0 and not above.toward_limit
    # A minimum: oxygen falling toward 19.5 % from above trends toward it; under it already does not.
    oxygen = Limit("%", warn_below=19.5)
    falling = trend_of("oxygen", points(20.9, 20.5, 20.1), oxygen)
    assert falling.side == "below" and falling.slope == pytest.approx(-0.4)
    assert falling.rounds_left == pytest.approx(1.5) and falling.toward_limit
    assert falling.words().endswith("at that rate under its 19.5 % limit within 2 rounds")
    assert not trend_of("oxygen", points(20.1, 19.7, 19.3), oxygen).toward_limit
    # A sensor with no limit has a slope and nothing to head for.
    free = trend_of("pressure", points(1.0, 2.0, 3.0), Limit("bar"))
    assert free.slope == pytest.approx(1.0) and free.limit is None and not free.toward_limit


def test_the_series_is_the_last_rounds_of_that_sensor_oldest_first() -> None:
    captures = [
        CaptureRecord(f"c-{i}", "robot1", 100.0 + i, 0.0, 0.0, 0.0, {"gas": float(i)} if i != 3 else {}, "m", "t")
        for i in range(TREND_ROUNDS + 3)
    ]
    series = series_of(captures, "gas")
    # 13 captures, the fourth without gas: the last ten of the twelve gas readings, 2 and then 4 to 12.
    assert [p.value for p in series] == [2.0, *(float(i) for i in range(4, TREND_ROUNDS + 3))]
    record = trend_of("gas", series, GAS).record()
    assert record == ReadingTrend("gas", "ppm", 400.0, tuple((p.t, p.value) for p in series))
    # The card's reading: one heading for its limit first, else the nearest its limit.
    near = trend_of("humidity", points(60.0, 60.0, 60.0), Limit("%", warn_above=70.0))
    rising = trend_of("gas", points(200.0, 280.0, 360.0), GAS)
    assert concern([near, rising]) is rising and concern([near, trend_of("gas", points(1.0), GAS)]) is near
    assert concern([]) is None and concern([trend_of("gas", [], GAS), near]) is near  # no readings: no concern


async def test_three_rounds_of_the_sims_rising_gas_make_one_trend_finding_in_the_third(tmp_path: Path) -> None:
    """The simulator's gas 2.1 m from the spill's source while the spill grows (robots.yaml: 10 % a minute), read
    by three rounds a minute apart (the world stepped by hand): 204.5, 284.2, 370.9 ppm against 400. The first two
    rounds are too few for a trend; the third makes a ``changed`` finding naming the gas, its three values and the
    crossing projected within a round, keeping the trend; temperature and humidity stay flat and make none."""
    config = load_config(ROOT / "robots.yaml")
    world = SimWorld(config, lambda *args: None)
    limits = {s.name: s for s in config.robots[0].sensors}
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "images") as store:

        async def on_store(work: Callable[[Store], Any], request_id: Any = None) -> Any:
            return work(store)

        watch = ChangeWatch(on_store, lambda: world.time)
        try:
            made = []
            for n in range(3):
                fields = world.fields_now()
                readings = {name: fields[limits[name].hazard].mean(1.8, 5.7) for name in limits}
                capture = store.add_capture(
                    CaptureRecord(f"c-{n}", "robot1", 1795388500.0 + world.time, 1.8, 5.7, 1.57, readings,
                                  f"m-{n}.robot1", "spill"), None,
                )  # fmt: skip
                trends = await watch.trends(capture, limits)
                assert [t.sensor for t in trends] == list(readings)
                made.append(watch.toward_limits(capture, trends, (1.8, 8.2)))
                for _ in range(60):
                    world.step(1.0)
            assert made[0] == made[1] == []
            [finding] = made[2]
            assert (finding.status, finding.source, finding.capture, finding.target) == (
                "changed",
                "rule",
                "c-2",
                "spill",
            )
            assert finding.note == (
                "trending toward its limit: gas 204.5, 284.2, 370.9 ppm over the last 3 rounds (+83.2 ppm a round): "
                "at that rate over its 400 ppm limit within 1 round"
            )
            assert finding.trend is not None and finding.trend.threshold == 400.0 and finding.trend.unit == "ppm"
            assert [round(v, 1) for _, v in finding.trend.points] == [204.5, 284.2, 370.9]
            assert store.add_finding(finding) == finding and store.finding(finding.id) == finding
        finally:
            watch.close()


def test_the_reports_sparkline_is_the_cards_geometry() -> None:
    """The same cases as the client's (xr_client/test/sparkline.test.js), worked out by hand there: 200, 280, 360
    ppm against 400 in a 100 x 50 box padded 5 take the range 180-420."""
    box = Box(100.0, 50.0, 5.0)
    line = sparkline([(1000.0, 200.0), (1060.0, 280.0), (1120.0, 360.0)], 400.0, box)
    assert (line.low, line.high) == (180.0, 420.0)
    assert [v for xy in line.points for v in xy] == pytest.approx(
        [5.0, 5 + 220 / 240 * 40, 50.0, 5 + 140 / 240 * 40, 95.0, 5 + 60 / 240 * 40]
    )
    assert line.limit == pytest.approx(5 + 20 / 240 * 40)
    assert polyline(line.points) == "5,41.7 50,28.3 95,15"
    spaced = sparkline([(0.0, 20.9), (60.0, 20.5), (180.0, 20.1)], 19.5, box)
    assert [x for x, _ in spaced.points] == pytest.approx([5.0, 35.0, 95.0])
    assert spaced.limit is not None and spaced.points[2][1] < spaced.limit <= 45.0
    one = sparkline([(5.0, 300.0)], None, box)
    assert (one.points, one.limit, one.low, one.high) == (((50.0, 25.0),), None, 285.0, 315.0)
    assert (sparkline([(0.0, 0.0), (1.0, 0.0)], None, box).low, sparkline([], None).points) == (-1.0, ())
    assert sparkline([], 400.0, SPARK_BOX).limit == SPARK_BOX.height / 2
    assert (label_y(6.0), label_y(30.0)) == (15.0, 28.0)
