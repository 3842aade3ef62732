"""Verdict helpers of registry version 1, frozen (used only by ``registry_v1``).

Building blocks of verdict rules: intervals over seeds and the four verdicts.

Across seeds we use Student's t interval (few seeds make 1.96·sd/√n overconfident):
mean ± t_{0.975, n−1} · sd/√n. A direction is *supported* when the interval of the paired
difference lies on the claimed side of zero, *contradicted* when it lies on the other side,
and *inconclusive* when it contains zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

from repro.core.stats import Interval, t_interval

REPRODUCED = "reproduced"
PARTIAL = "partially reproduced"
NOT_REPRODUCED = "not reproduced"
PAPER_DISCREPANCY = "discrepancy in the paper"
VERDICTS = (REPRODUCED, PARTIAL, NOT_REPRODUCED, PAPER_DISCREPANCY)

Direction = Literal["supported", "inconclusive", "contradicted"]


@dataclass
class Decision:
    """A verdict with the reason in words and each check that led to it."""

    verdict: str
    reason: str
    checks: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {self.verdict!r}; expected one of {VERDICTS}")


def direction(differences: Sequence[float], claimed: Literal["positive", "negative"]) -> Direction:
    """Is the paired difference on the claimed side of zero, across seeds?"""
    interval = t_interval(differences)
    if interval.n == 1:  # one seed cannot support a direction, only hint at it
        return "inconclusive"
    above, below = interval.low > 0, interval.high < 0
    if claimed == "positive":
        return "supported" if above else "contradicted" if below else "inconclusive"
    return "supported" if below else "contradicted" if above else "inconclusive"


def best_option(claimed: str, per_option: dict[str, Sequence[float]],
                lower_is_better: bool) -> Direction:
    """Is ``claimed`` the best option? supported: best mean and its interval clear of every
    other's; inconclusive: best mean but overlapping, or not best but overlapping the best;
    contradicted: another option is better with intervals apart."""
    if claimed not in per_option:
        raise ValueError(f"option {claimed!r} not measured; have {sorted(per_option)}")
    sign = 1.0 if lower_is_better else -1.0
    intervals = {k: t_interval(v) for k, v in per_option.items()}
    score = {k: sign * iv.mean for k, iv in intervals.items()}
    best = min(score, key=score.__getitem__)
    mine = intervals[claimed]

    def apart(x: Interval, y: Interval) -> bool:
        return x.high < y.low or y.high < x.low

    if best == claimed:
        others = [iv for k, iv in intervals.items() if k != claimed]
        return "supported" if all(apart(mine, o) for o in others) else "inconclusive"
    return "contradicted" if apart(mine, intervals[best]) else "inconclusive"


def combine(parts: dict[str, Direction], required: Sequence[str] | None = None) -> str:
    """Reproduced if every required part is supported; not reproduced if none is supported
    or any is contradicted while none is supported; partially otherwise."""
    names = list(required) if required is not None else list(parts)
    outcomes = [parts[n] for n in names]
    if all(o == "supported" for o in outcomes):
        return REPRODUCED
    if not any(o == "supported" for o in outcomes):
        return NOT_REPRODUCED
    return PARTIAL
