"""relay.session.freshness: ages of stamped messages when the sender's clock and the receiver's do not agree."""

from __future__ import annotations

import pytest

from relay.session.freshness import CREEP, SenderClock


def test_ages_are_relative_to_the_quickest_message_whatever_the_clock_offset() -> None:
    for offset in (-1e6, 0.0, 3.25, 1e9):  # the sender's clock far behind, equal, ahead
        clock = SenderClock()
        # 20 Hz, each message 5-20 ms in transit.
        ages = [clock.age(t + offset, t + 0.005 + 0.015 * (i % 2)) for i, t in enumerate(x * 0.05 for x in range(40))]
        assert max(ages) == pytest.approx(0.015, abs=CREEP * 0.1) and min(ages) == pytest.approx(0.0, abs=1e-6)
        # A message that waited 2 s (a frozen receiver, a stalled network) reads 2 s old, less the creep.
        assert clock.age(2.0 + offset, 4.005) == pytest.approx(2.0 - CREEP * 2.04, abs=0.005)


def test_a_sender_whose_clock_was_stepped_back_is_believed_again() -> None:
    clock = SenderClock()
    for i in range(20):
        clock.age(i * 0.05, i * 0.05 + 0.01)
    # The sender's clock steps back 1 s: its messages look 1 s old, then younger as the estimate creeps up.
    first = clock.age(1.0 - 1.0, 1.01)
    assert first == pytest.approx(1.0, abs=0.01)
    t, age = 1.01, first
    while age > 0.1 and t < 100:
        t += 0.05
        age = clock.age(t - 0.01 - 1.0, t)
    assert t - 1.01 == pytest.approx((1.0 - 0.1) / CREEP, rel=0.05)  # ~45 s for a 1 s step


def test_a_clock_stepped_forward_only_makes_messages_look_fresh() -> None:
    clock = SenderClock()
    clock.age(0.0, 0.01)
    assert clock.age(10.0, 0.06) == 0.0  # the new quickest
    assert clock.age(10.05, 0.11) == pytest.approx(0.0, abs=1e-6)
