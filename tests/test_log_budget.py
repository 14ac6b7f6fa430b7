"""Log lines about what others send (relay/logs/budget.py): the rule with the time passed in, and the logger behind
it, without sockets."""

from __future__ import annotations

import logging
import threading

import pytest

from relay.logs.budget import BudgetedLog, LogBudget


def test_a_period_allows_its_lines_and_counts_the_rest_for_one_summary() -> None:
    budget = LogBudget(lines=3, period=10.0)
    assert [budget.take(100.0 + i * 0.1) for i in range(5)] == [(True, 0)] * 3 + [(False, 0)] * 2
    assert budget.overdue(109.9) == 0  # the period still runs
    # The next line after the period: allowed, with the two left out to summarise first.
    assert budget.take(110.0) == (True, 2)
    assert budget.overdue(200.0) == 0  # nothing left out since
    # A period that ends with lines left out and no line after: the ticker's overdue() gives them, once.
    for _ in range(7):
        budget.take(300.0)
    assert budget.overdue(305.0) == 0 and budget.overdue(310.0) == 4 and budget.overdue(320.0) == 0


def test_a_clock_that_goes_back_starts_a_new_period_rather_than_none() -> None:
    budget = LogBudget(lines=1, period=10.0)
    assert budget.take(50.0) == (True, 0) and budget.take(51.0) == (False, 0)
    assert budget.take(40.0) == (True, 1)


def test_3000_lines_from_four_threads_write_the_budget_and_one_summary(caplog: pytest.LogCaptureFixture) -> None:
    """3000 malformed samples wrote 3000 warnings (issue 28, finding 6): the budget writes 10 and then, once the
    period is over, one line naming the 2990 left out."""
    now = [0.0]
    log = BudgetedLog(logging.getLogger("test.peers"), "peers", lines=10, period=60.0, clock=lambda: now[0])
    caplog.set_level(logging.INFO, "test.peers")

    def flood() -> None:
        for i in range(750):
            log.warning("bad sample %d", i)

    threads = [threading.Thread(target=flood) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    log.flush()
    assert len(caplog.records) == 10 and log.dropped == 2990
    now[0] = 60.0
    log.flush()
    log.flush()
    assert len(caplog.records) == 11
    assert caplog.records[-1].getMessage() == "peers: 2990 more lines like these were left out (at most 10 every 60 s)"
