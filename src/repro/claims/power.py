"""How many seeds a part needs: the power of the one-sided paired t-test the verdicts use.

With n seeds and per-seed differences of spread σ, the statistic of "mean > 0" follows a
noncentral t with n − 1 degrees of freedom and noncentrality δ√n/σ when the true effect is
δ; the power is P(T > t_{1−α, n−1}) (scipy's ``nct``). A part of a claim with k parts is
tested at α/k here: Holm's first step, so the number holds for the part Holm tests first and
is conservative for the others. The registered ``seeds`` of every part is
``seeds_for_power`` at its smallest effect of interest on the spread of the v1 full run in
``results/claims.json`` (tests/claims/test_power.py recomputes them); a v3 measurement the v1
run did not record under its name is powered on the v1 values of its nearest measurement
(:data:`V1_NEAREST`, :data:`V1_PROXIES`, :func:`v1_measured`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from repro.claims.verdicts import ALPHA, POWER, Part

MAX_SEEDS = 1000

#: v3 measurement → the v1 method (``extra.per_method``, per seed ``location_error``) nearest
#: to it. GMD-B2 (issue #17): v1's abs imputation and both guidance runs were sampled at T =
#: 100; its rel imputation nearest the v3 one is the velocity replacement of every frame.
V1_NEAREST: dict[str, dict[str, str]] = {
    "GMD-B2": {"abs_imputation_error": "abs_imputation",
               "rel_imputation_error": "rel_velocity_replacement",
               "abs_guidance_error": "abs_guidance", "rel_guidance_error": "rel_guidance"},
}


def power_of(n: int, effect: float, spread: float, alpha: float = ALPHA) -> float:
    """Power of the one-sided one-sample t-test with ``n`` seeds at true mean ``effect``."""
    if n < 2:
        return 0.0
    if spread == 0.0:
        return 1.0 if effect > 0 else 0.0
    critical = stats.t.ppf(1 - alpha, n - 1)
    return float(stats.nct.sf(critical, n - 1, effect / spread * math.sqrt(n)))


def seeds_for_power(effect: float, spread: float, *, alpha: float = ALPHA,
                    power: float = POWER) -> int:
    """The fewest seeds (≥ 2) with ``power`` at ``effect``; ``MAX_SEEDS`` if none up to it."""
    for n in range(2, MAX_SEEDS + 1):
        if power_of(n, effect, spread, alpha) >= power:
            return n
    return MAX_SEEDS


def part_seeds(part: Part, measured: Mapping[str, Any], parts_in_claim: int) -> int:
    """The seeds ``part`` needs, from the spread of its differences in ``measured`` (a v1
    full run) at its smallest effect of interest there: the largest over its comparisons.
    Non-inferiority parts need the power to reject "worse by δ" at a true difference of 0,
    which is the same calculation."""
    needed = 2
    for comparison in part.compare(measured):
        values = np.asarray(comparison.differences, dtype=np.float64)
        spread = float(values.std(ddof=1)) if values.size > 1 else 0.0
        needed = max(needed, seeds_for_power(comparison.smallest_effect, spread,
                                             alpha=ALPHA / parts_in_claim))
    return needed


#: v3 measurement → the v1 measurement (same sidecar's ``measured``) whose spread it is powered
#: on. EMG-5 (issue #16): the transitions at the timelines' boundaries → the all-frames
#: transition distance (its spread relative to its mean is what δ, relative too, meets);
#: EMG-6: the floor → the unrelated control it replaces as the compared arm.
V1_PROXIES: dict[str, dict[str, str]] = {
    "EMG-5": {"transition_distance_at_transitions": "transition_distance",
              "transition_speed_ratio": "transition_distance"},
    "EMG-6": {f"{case}_similarity_floor": f"{case}_similarity_to_control"
              for case in ("conjunction", "negation")},
}


#: parts whose measurements no v1 full run recorded (registry v3): the δ/σ their registered
#: ``seeds`` come from (``power.seeds_for_power(δ/σ, 1)`` at α/parts), with where σ comes from.
#: The first v3 full run's spreads replace these.
POWER_WITHOUT_V1_RUN: dict[tuple[str, str], tuple[float, str]] = {
    ("GMD-A3", "eps_keeps_more_of_best_gain"): (
        0.1 / (np.sqrt(2) * 0.06709583156114049),
        "v1 recorded the same share outside the rule (extra goal_error_kept_from_best, T = 100): "
        "x0 arm 0.79 / 0.74 / 0.66, sd 0.067; the ε arm's is undefined (its guidance never "
        "gained), so σ of the difference is taken as √2 × 0.067 (two arms of that spread)"),
    ("GMD-F1", "stop_at_20_more_coherent"): (
        0.05 * 127713.5697 / 0.03613,
        "no whole-body measurement in v1; the nearest is v1's root jerk stop 0 − stop 20 "
        "(δ 5 % of 1.277×10⁵ m/s³ over σ 0.036 m/s³, T = 100, where the stop moved 2 of 100 "
        "steps): 2 seeds, which says nothing about T = 1000"),
}


def v1_measured(claim_id: str, sidecar: Mapping[str, Any]) -> dict[str, Any]:
    """A v1 sidecar's ``measured`` with the claim's v3 measurements added: each
    :data:`V1_NEAREST` one as the per-seed location errors of its nearest v1 method (in seed
    order), each :data:`V1_PROXIES` one as its v1 proxy's values."""
    measured = dict(sidecar["measured"])
    for name, proxy in V1_PROXIES.get(claim_id, {}).items():
        measured.setdefault(name, measured[proxy])
    for name, method in V1_NEAREST.get(claim_id, {}).items():
        per_seed = sidecar["extra"]["per_method"][method]
        measured[name] = [per_seed[s]["location_error"] for s in sorted(per_seed, key=int)]
    return measured


def claim_seeds(parts: Sequence[Part], measured: Mapping[str, Any]) -> dict[str, int]:
    """``part_seeds`` for every part of a claim."""
    return {p.name: part_seeds(p, measured, len(parts)) for p in parts}
