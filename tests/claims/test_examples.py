"""Every rule that rests on measured effects, fed its own null and planted examples: no effect
must rarely pass (≤ 5 % reproduced or partially over 200 draws), the registered effect must
be reproduced, and identical quantised arms must come out below resolution."""

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
    PARTIAL,
    REPRODUCED,
    SUPPORTED,
)

EFFECT_CLAIMS = [c.id for c in CLAIMS.values() if c.rests_on_effects]


def _rng(claim_id: str, salt: str) -> np.random.Generator:
    """A generator fixed by the claim's ID (not chosen per claim)."""
    return np.random.default_rng(zlib.crc32(f"{claim_id}/{salt}".encode()))


def test_every_effect_claim_has_examples_and_the_exact_ones_do_not() -> None:
    assert len(EFFECT_CLAIMS) == 13
    for claim in CLAIMS.values():
        if claim.rests_on_effects:
            assert claim.example is not None, claim.id
            example = claim.null_example(np.random.default_rng(0))
            assert set(claim.measurements) <= set(example), claim.id
        else:
            with pytest.raises(ValueError, match="exact checks"):
                claim.null_example(np.random.default_rng(0))


@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_null_examples_rarely_pass(claim_id: str) -> None:
    claim, rng = get_claim(claim_id), _rng(claim_id, "null")
    verdicts = [claim.decide(claim.null_example(rng)).verdict for _ in range(200)]
    share = sum(v in (REPRODUCED, PARTIAL) for v in verdicts) / len(verdicts)
    assert share <= 0.05, f"{claim_id}: {share:.1%} of 200 null draws pass"


@pytest.mark.parametrize("claim_id", EFFECT_CLAIMS)
def test_planted_examples_are_reproduced(claim_id: str) -> None:
    claim, rng = get_claim(claim_id), _rng(claim_id, "planted")
    for _ in range(20):
        decision = claim.decide(claim.planted_example(rng))
        assert decision.verdict == REPRODUCED, f"{claim_id}: {decision.reason}"


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


def test_emg_7_says_when_the_run_cannot_separate_n_at_the_registered_power() -> None:
    """Issue #16: if the stand-in cannot separate N at the registered power, the verdict says
    so. With the seeds a full run affords (fewer than either part's power calculation asks
    for) and no difference between the N, no part is called absent or contradicted: each is
    inconclusive, and its reason names the missing power."""
    claim = get_claim("EMG-7")
    assert all(part.seeds > claim.affordable_seeds for part in claim.parts)
    assert "affords 3 seeds" in claim.power_note
    for draw in range(5):
        measured = claim.null_example(np.random.default_rng(draw))
        for part in claim.decide(measured).parts:
            assert part.outcome == INCONCLUSIVE, part.reason
            assert f"of the {next(p.seeds for p in claim.parts if p.name == part.name)} " \
                   "the power calculation asks for" in part.reason
