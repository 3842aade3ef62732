"""How many seeds each GMD claim's experiment runs: the one table (registry v4).

Registry v4 plans no seed count from an earlier run's spread: a run uses the seeds its
budget affords, and each part states from its own interval what it could have seen
(``claims.power.minimum_detectable_effect``). Notebook 01's A3 and A4 share one seed list
(the same trajectory models), as do F1's trajectory and motion models. Quick runs use one.
"""

from __future__ import annotations

__all__ = ["FULL_SEEDS", "QUICK_SEEDS", "seeds_of"]

FULL_SEEDS: dict[str, int] = {
    "GMD-A3": 3, "GMD-A4": 3,   # notebook 01: two trajectory + motion models per seed
    "GMD-B2": 3,                # notebook 02: two trajectory models, six methods at T = 1000
    "GMD-B3": 5,                # notebook 02: two motion models per seed
    "GMD-C4": 6,                # notebook 03: two values × two arms per seed (24 models)
    "GMD-F1": 3,                # notebook 06
}
QUICK_SEEDS = 1


def seeds_of(claim_id: str, quick: bool) -> int:
    """The seeds ``claim_id``'s experiment runs (``QUICK_SEEDS`` in quick mode)."""
    if claim_id not in FULL_SEEDS:
        raise ValueError(f"no seed count for {claim_id!r}; have {sorted(FULL_SEEDS)}")
    return QUICK_SEEDS if quick else FULL_SEEDS[claim_id]
