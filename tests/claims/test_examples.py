"""Every rule that rests on measured effects, fed its own examples at 3, 5 and 6 seeds (the
seed counts runs use: ``gmd.settings``, ``energymogen.settings``): an effect of +3δ must come
out reproduced in ≥ 90 % of draws, the same effect reversed (−3δ, the paper wrong) not
reproduced in ≥ 80 %, no effect reproduced or partially in ≤ 8 %, and identical quantised arms
below resolution (under v3, −3δ came out "inconclusive" in every draw for 11 of the 13). A
log-ratio part's δ is on the log scale, and so are its examples' effects."""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np
import pytest

from repro.claims.registry import CLAIMS, get_claim
from repro.claims.verdicts import (
    BELOW_RESOLUTION,
    CONTRADICTED,
    INCONCLUSIVE,
    NOT_REPRODUCED,
    PARTIAL,
    REPRODUCED,
    SUPPORTED,
)
from repro.energymogen import settings as emg_settings
from repro.gmd import settings as gmd_seeds

EFFECT_CLAIMS = [c.id for c in CLAIMS.values() if c.rests_on_effects]
RUN_SEEDS = {**gmd_seeds.FULL_SEEDS, **emg_settings.FULL_SEEDS}
DRAWS = 200
#: the seed counts every symmetric check runs at
SEED_COUNTS = (3, 5, 6)


def _rng(claim_id: str, salt: str) -> np.random.Generator:
    """A generator fixed by the claim's ID (not chosen per claim)."""
    return np.random.default_rng(zlib.crc32(f"{claim_id}/{salt}".encode()))


def test_every_effect_claim_has_examples_and_run_seeds_and_the_exact_ones_do_not() -> None:
    assert len(EFFECT_CLAIMS) == 13
    assert sorted(RUN_SEEDS) == sorted(EFFECT_CLAIMS)
    for claim in CLAIMS.values():
        if claim.rests_on_effects:
            assert claim.example is not None, claim.id
            example = claim.null_example(np.random.default_rng(0))
            assert set(claim.measurements) <= set(example), claim.id
        else:
            with pytest.raises(ValueError, match="exact checks"):
                claim.null_example(np.random.default_rng(0))


def _verdicts(claim_id: str, scale: float, salt: str, n: int) -> list[str]:
    claim, rng = get_claim(claim_id), _rng(claim_id, f"{salt}/{n}")
    return [claim.decide(claim.example_at(rng, scale, n)).verdict for _ in range(DRAWS)]


@pytest.mark.parametrize("n", SEED_COUNTS)
@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_three_deltas_for_the_paper_are_reproduced(claim_id: str, n: int) -> None:
    verdicts = _verdicts(claim_id, 3.0, "for", n)
    share = verdicts.count(REPRODUCED) / DRAWS
    assert share >= 0.9, f"{claim_id}: {share:.1%} of {DRAWS} draws at +3δ, {n} seeds reproduced"


@pytest.mark.parametrize("n", SEED_COUNTS)
@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_three_deltas_against_the_paper_are_not_reproduced(claim_id: str, n: int) -> None:
    verdicts = _verdicts(claim_id, -3.0, "against", n)
    share = verdicts.count(NOT_REPRODUCED) / DRAWS
    assert share >= 0.8, (f"{claim_id}: {share:.1%} of {DRAWS} draws at −3δ, {n} seeds not "
                          "reproduced")


@pytest.mark.parametrize("n", SEED_COUNTS)
@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_no_effect_rarely_passes(claim_id: str, n: int) -> None:
    verdicts = _verdicts(claim_id, 0.0, "null", n)
    share = sum(v in (REPRODUCED, PARTIAL) for v in verdicts) / DRAWS
    assert share <= 0.08, f"{claim_id}: {share:.1%} of {DRAWS} null draws, {n} seeds pass"


def test_the_seed_counts_checked_cover_every_run() -> None:
    assert set(RUN_SEEDS.values()) <= set(SEED_COUNTS)
    assert min(SEED_COUNTS) == 3


@pytest.mark.parametrize("n", SEED_COUNTS)
@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_every_part_can_fail(claim_id: str, n: int) -> None:
    """Each part fed its own example with the paper wrong (−3δ): no part is supported."""
    claim = get_claim(claim_id)
    for draw in range(10):
        measured = claim.example_at(_rng(claim_id, f"fail{draw}"), -3.0, n)
        for part in claim.decide(measured).parts:
            assert part.outcome != SUPPORTED, f"{claim_id} {part.name}: {part.reason}"


def _identical_arms(measured: dict[str, Any], values: list[float]) -> dict[str, Any]:
    """Every per-seed list replaced by the same values (arms that cannot differ)."""
    out: dict[str, Any] = {}
    for key, value in measured.items():
        if isinstance(value, dict):
            out[key] = _identical_arms(value, values)
        elif isinstance(value, list) and key != "values":
            out[key] = list(values)
        else:
            out[key] = value
    return out


# claims whose every effect part compares two arms (no threshold like "≤ half the baseline")
TWO_ARM_CLAIMS = ["GMD-A3", "GMD-A4", "GMD-B3", "GMD-C4", "EMG-4", "EMG-5", "EMG-6", "EMG-7",
                  "EMG-8"]


@pytest.mark.parametrize("claim_id", TWO_ARM_CLAIMS)
def test_identical_quantised_arms_are_below_resolution(claim_id: str) -> None:
    claim = get_claim(claim_id)
    example = claim.null_example(np.random.default_rng(1))
    measured = _identical_arms(example, [53 / 64, 50 / 64, 49 / 64])
    if claim_id == "GMD-B3":
        measured["diversity_real"] = 1.0
    decision = claim.decide(measured)
    kinds = {p.name: p.kind for p in claim.parts}
    for part in decision.parts:
        if kinds[part.name] == "effect":
            assert part.outcome == BELOW_RESOLUTION, f"{claim_id} {part.name}: {part.reason}"
        assert part.outcome not in (CONTRADICTED,)
    assert decision.verdict == INCONCLUSIVE


def test_emg_8_one_clip_in_384_is_below_resolution_not_contradicted() -> None:
    base = [216 / 384, 228 / 384, 210 / 384]       # the shared-concept test: 384 clips
    measured = {"r_precision_top3_baseline": base,
                "r_precision_top3_augmented": [b - 1 / 384 for b in base],
                "fid_baseline": [0.104, 0.107, 0.108], "fid_augmented": [0.106, 0.107, 0.109]}
    decision = get_claim("EMG-8").decide(measured)
    assert decision.checks["r_precision_improves"] == BELOW_RESOLUTION
    measured["r_precision_top3_augmented"] = [b - 2 / 384 for b in base]   # two clips: not
    assert get_claim("EMG-8").decide(measured).checks["r_precision_improves"] != \
        BELOW_RESOLUTION


def test_gmd_b3_r_precision_tie_alone_is_not_partial() -> None:
    same = [0.5, 0.45, 0.52]
    measured = {"fid_rel": same, "fid_abs": [0.51, 0.44, 0.53],
                "r_precision_top3_rel": [0.2109375, 0.19921875, 0.23828125],
                "r_precision_top3_abs": [0.2109375, 0.19921875, 0.23828125],
                "diversity_rel": [1.1, 1.12, 1.08], "diversity_abs": [1.11, 1.1, 1.09],
                "diversity_real": 1.36}
    decision = get_claim("GMD-B3").decide(measured)
    assert decision.checks["abs_r_precision_not_worse"] == SUPPORTED
    assert decision.verdict not in (REPRODUCED, PARTIAL)


def test_emg_7_says_what_its_run_could_see() -> None:
    """Issue #16: if the stand-in cannot separate N, the verdict says so — v4 from the run's
    own spread: with no difference between the N at the run's seeds, a part that is neither
    absent nor contradicted says which effect this run could have seen beside δ."""
    claim = get_claim("EMG-7")
    for draw in range(5):
        measured = claim.null_example(np.random.default_rng(draw), RUN_SEEDS["EMG-7"])
        for part in claim.decide(measured).parts:
            assert part.outcome != SUPPORTED
            if part.outcome == INCONCLUSIVE:
                assert "this run could see" in part.reason and "δ is" in part.reason
