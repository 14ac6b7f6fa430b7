"""Per-client message rate limit: a token bucket, a pure rule that takes the time as an argument."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class TokenBucket:
    """``rate`` messages a second sustained, bursts of ``2 * rate``.

    A client starts with a full bucket, so a page that sends its subscriptions right after ``hello`` is never
    refused; after that it earns ``rate`` tokens a second.
    """

    rate: float
    tokens: float
    last: float

    @classmethod
    def full(cls, rate: float, now: float) -> TokenBucket:
        return cls(rate, 2 * rate, now)

    def take(self, now: float) -> bool:
        """Spend one token if there is one; False means the message must be dropped."""
        tokens = min(2 * self.rate, self.tokens + (now - self.last) * self.rate)
        self.last = now
        if tokens < 1.0:
            self.tokens = tokens
            return False
        self.tokens = tokens - 1.0
        return True
