"""Scalar sensor fields of the demo scenario (gas, temperature, humidity).

Each field is a baseline plus Gaussian blobs around point sources plus white
sensor noise, evaluated at a map position (REP 103 map frame, metres). The
dataclasses are deliberately plain (floats, strings, tuples) so a config
loader builds them from the ``sim`` section of ``robots.yaml``
(:func:`relay.sim.world.build_fields`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HazardSource", "SensorField"]


@dataclass(frozen=True)
class HazardSource:
    """A point source adding ``peak * exp(-d^2 / (2 sigma^2))`` at distance ``d`` (metres).

    ``sigma`` must be > 0; ``peak`` may be negative (a cold spot).
    """

    kind: str
    x: float
    y: float
    peak: float
    sigma: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sigma) and self.sigma > 0.0):
            raise ValueError(f"HazardSource sigma must be > 0, got {self.sigma!r}")


@dataclass(frozen=True)
class SensorField:
    """One measured quantity over the facility.

    ``kind`` names the quantity (``"gas"``, ``"temperature"``, ...), ``unit``
    its unit for display; ``noise`` is the standard deviation (>= 0) of the
    additive Gaussian sensor noise.
    """

    kind: str
    baseline: float
    noise: float
    sources: tuple[HazardSource, ...] = ()
    unit: str = ""
    #: The lowest value the quantity can take (0 for a concentration or a relative humidity): noise is clipped at
    #: it, so a gas sensor never reports negative ppm. None: no floor (a temperature).
    minimum: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.noise) and self.noise >= 0.0):
            raise ValueError(f"SensorField noise must be >= 0, got {self.noise!r}")

    def mean(self, x: float, y: float) -> float:
        """Noise-free value at ``(x, y)``: baseline plus every source's smooth falloff."""
        total = self.baseline
        for s in self.sources:
            d2 = (x - s.x) ** 2 + (y - s.y) ** 2
            total += s.peak * math.exp(-d2 / (2.0 * s.sigma * s.sigma))
        return total

    def value(self, x: float, y: float, rng: np.random.Generator) -> float:
        """A noisy reading at ``(x, y)``: :meth:`mean` plus ``N(0, noise)`` drawn from ``rng``.

        The caller owns ``rng`` (one per robot keeps runs reproducible and
        robots independent). Exactly one normal draw is consumed per call,
        even when ``noise`` is 0, so streams stay aligned across configs.
        """
        value = self.mean(x, y) + self.noise * float(rng.standard_normal())
        return value if self.minimum is None else max(self.minimum, value)
