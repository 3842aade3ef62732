"""How many seeds each GMD claim's experiment runs, per scale: the one table (registry v4).

Registry v4 plans no seed count from an earlier run's spread: a run uses the seeds its
budget affords, and each part states from its own interval what it could have seen
(``claims.power.minimum_detectable_effect``). Notebook 01's A3 and A4 share one seed list
(the same trajectory models), as do F1's trajectory and motion models. The paper scale runs
``FULL_SEEDS`` (the registered full settings), the standard scale 3 for every claim but GMD-C4
(docs/COMPUTE.md §3a item 5), quick runs one. GMD-C4 runs one seed at standard
(docs/COMPUTE.md §13): its arms pass their gate only from 1500 steps, its part needs ≈ 340× δ at
3 seeds (no standard seed count decides it), so the budget buys one seed of models that pass.
"""

from __future__ import annotations

from repro.infra.context import check_scale

__all__ = ["FULL_SEEDS", "QUICK_SEEDS", "STANDARD_SEEDS", "seeds_of"]

#: the paper scale's seeds (today's registered full settings)
FULL_SEEDS: dict[str, int] = {
    "GMD-A3": 3, "GMD-A4": 3,   # notebook 01: two trajectory + motion models per seed
    "GMD-B2": 3,                # notebook 02: two trajectory models, six methods at T = 1000
    "GMD-B3": 5,                # notebook 02: two motion models per seed
    "GMD-C4": 6,                # notebook 03: two values × two arms per seed (24 models)
    "GMD-F1": 3,                # notebook 06
}
#: the standard scale's seeds: 3 for every GMD claim but GMD-C4 (one seed, 1500 steps)
STANDARD_SEEDS: dict[str, int] = {**dict.fromkeys(FULL_SEEDS, 3), "GMD-C4": 1}
QUICK_SEEDS = 1


def seeds_of(claim_id: str, scale: str) -> int:
    """The seeds ``claim_id``'s experiment runs at ``scale`` (quick, standard or paper)."""
    check_scale(scale)
    if claim_id not in FULL_SEEDS:
        raise ValueError(f"no seed count for {claim_id!r}; have {sorted(FULL_SEEDS)}")
    return {"quick": QUICK_SEEDS, "standard": STANDARD_SEEDS[claim_id],
            "paper": FULL_SEEDS[claim_id]}[scale]
