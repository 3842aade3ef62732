"""Statistics over seeds: Student-t intervals and paired differences.

Across seeds we use Student's t interval (few seeds make 1.96·sd/√n overconfident):
mean ± t_{0.975, n−1} · sd/√n. The verdict rules (``repro.claims.verdicts``) and the paper
packages' tables both use these, so they live below both.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class Interval:
    mean: float
    low: float
    high: float
    n: int

    def as_dict(self) -> dict[str, float]:
        return {"mean": self.mean, "low": self.low, "high": self.high, "n": self.n}

    def __str__(self) -> str:
        return f"{self.mean:.4g} [{self.low:.4g}, {self.high:.4g}] (n={self.n})"



def t_interval(values: Sequence[float], confidence: float = 0.95) -> Interval:
    """Mean and Student-t confidence interval of per-seed values (a single value: no width)."""
    array = np.asarray(values, dtype=np.float64).ravel()
    if array.size == 0:
        raise ValueError("t_interval needs at least one value")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"t_interval got non-finite values: {array.tolist()}")
    mean = float(array.mean())
    if array.size == 1:
        return Interval(mean, mean, mean, 1)
    half = float(stats.t.ppf(0.5 + confidence / 2, array.size - 1) * array.std(ddof=1)
                 / np.sqrt(array.size))
    return Interval(mean, mean - half, mean + half, int(array.size))


def paired_difference(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """a − b, seed by seed (both lists are indexed by the same seeds)."""
    if len(a) != len(b):
        raise ValueError(f"paired values need the same seeds: {len(a)} vs {len(b)} values")
    return [float(x) - float(y) for x, y in zip(a, b, strict=True)]
