"""Power of the one-sided paired t-test the verdicts use, and what a run could see.

With n seeds and per-seed differences of spread σ, the statistic of "mean > 0" follows a
noncentral t with n − 1 degrees of freedom and noncentrality Δ√n/σ when the true effect is
Δ; the power is P(T > t_{1−α, n−1}) (scipy's ``nct``). Registry v4 plans no seed count from
another run's spread: each part states what *its own run* could have seen, the minimum
detectable effect (MDE) — the true effect at which the run's n and its own spread give 80 %
power — beside the smallest effect of interest δ. A part is tested at α/k here (Holm's first
step over a claim's k parts), so the MDE is the one of the part Holm tests first and is
conservative for the others. Where a part stays undecided, :func:`seeds_to_see` says how
many seeds would see δ at the run's own spread.
"""

from __future__ import annotations

import functools
import math

from scipy import optimize, stats

ALPHA = 0.025            # one-sided, family-wise over a claim's parts (Holm)
POWER = 0.8


def power_of(n: int, effect: float, spread: float, alpha: float = ALPHA) -> float:
    """Power of the one-sided one-sample t-test with ``n`` seeds at true mean ``effect``."""
    if n < 2:
        return 0.0
    if spread == 0.0:
        return 1.0 if effect > 0 else 0.0
    critical = stats.t.ppf(1 - alpha, n - 1)
    return float(stats.nct.sf(critical, n - 1, effect / spread * math.sqrt(n)))


@functools.lru_cache(maxsize=4096)
def _noncentrality_for_power(n: int, alpha: float, power: float) -> float:
    """λ with P(T > t_{1−α, n−1}) = ``power`` for T ~ noncentral t(n − 1, λ)."""
    critical = stats.t.ppf(1 - alpha, n - 1)
    high = float(critical + stats.norm.ppf(power)) + 2.0
    while stats.nct.sf(critical, n - 1, high) < power:
        high *= 2.0
    return float(optimize.brentq(lambda lam: stats.nct.sf(critical, n - 1, lam) - power,
                                 0.0, high, xtol=1e-10))


def minimum_detectable_effect(n: int, spread: float, *, alpha: float = ALPHA,
                              power: float = POWER) -> float:
    """The true mean effect at which ``n`` seeds of per-seed spread ``spread`` reach ``power``:
    λ·σ/√n, λ the noncentrality at which the test's power is ``power`` (:func:`power_of`
    depends on the effect only through λ = Δ√n/σ); ``inf`` with fewer than two seeds, 0 with
    no spread."""
    if n < 2:
        return math.inf
    if spread == 0.0:
        return 0.0
    return _noncentrality_for_power(n, alpha, power) * spread / math.sqrt(n)


#: the most seeds :func:`seeds_to_see` looks at; beyond it a run "would need more"
MOST_SEEDS = 100_000


def seeds_to_see(effect: float, spread: float, *, alpha: float = ALPHA, power: float = POWER,
                 most: int = MOST_SEEDS) -> int | None:
    """The fewest seeds n ≥ 2 at which a true mean ``effect`` with per-seed spread ``spread``
    reaches ``power`` (:func:`power_of`: noncentrality effect·√n/σ, n − 1 degrees of
    freedom); 2 with no spread and a positive effect; None if no n up to ``most`` does (or the
    effect is not positive). Power grows with n, so the search doubles n and then bisects."""
    if effect <= 0 or not math.isfinite(spread):
        return None
    if power_of(2, effect, spread, alpha) >= power:
        return 2
    low, high = 2, 4
    while power_of(high, effect, spread, alpha) < power:
        if high >= most:
            return None
        low, high = high, min(2 * high, most)
    while high - low > 1:
        middle = (low + high) // 2
        if power_of(middle, effect, spread, alpha) >= power:
            high = middle
        else:
            low = middle
    return high
