"""Gates version 5: the registry's part × property × arms table, and a gate that holds a part
back only on a property the part reads of a model whose arm differs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import pytest

from repro.claims.gating import (
    COMMON,
    WORSE,
    Reading,
    gate_table,
    held_back,
    violations,
)
from repro.claims.registry import CLAIMS, READINGS
from repro.core.gates import GATES, TRAINING_GATES
from repro.energymogen.model_gates import COMPARED as EMG_COMPARED
from repro.energymogen.model_gates import FAMILIES_READ as EMG_FAMILIES
from repro.gmd.model_gates import COMPARED as GMD_COMPARED
from repro.gmd.model_gates import FAMILIES_READ as GMD_FAMILIES

FAMILIES = {**GMD_FAMILIES, **EMG_FAMILIES}
COMPARED = {**GMD_COMPARED, **EMG_COMPARED}
#: the families a model of a claim's arm can be (the evaluator is shared by every arm)
TRAINED = ("gmd_motion", "gmd_trajectory", "vae", "latent_denoiser")


def _failing(name: str, family: str, arm: str | None, steps: int = 100) -> dict[str, Any]:
    """A record that failed every gate of its family."""
    gates = {g.metric: {"value": None, "passed": False} for g in GATES[family]}
    return {"name": name, "family": family, "arm": arm, "gate": gates, "passed": False,
            "reads": None, "steps": steps}


def _records(claim_id: str, reading: Reading) -> list[dict[str, Any]]:
    """One failing model per arm and trained family the claim reads, one shared by every arm."""
    families = [f for f in FAMILIES[claim_id] if f in TRAINED]
    records = [_failing(f"{family} {arm}", family, arm)
               for arm in reading.arms for family in families]
    return records + [_failing(f"{family} shared", family, None) for family in FAMILIES[claim_id]]


def _v4(readings: Mapping[str, Reading], records: Sequence[Mapping[str, Any]],
        parts: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Gates version 4: a model that fails any of its gates holds back every part it is read
    by (the reference role's sample gates included), whatever the part reads."""
    return {r["name"]: {"holds_back": {} if r["passed"] else {
        p: [m for m, g in r["gate"].items() if not g["passed"]]
        for p in (parts if r.get("reads") is None else r["reads"])}} for r in records}


def _model_parts() -> list[tuple[str, str, Reading]]:
    return [(claim_id, part, reading) for claim_id, parts in READINGS.items()
            for part, reading in parts.items()]


def test_every_part_of_a_model_based_claim_states_what_it_reads() -> None:
    for claim_id in FAMILIES:
        assert claim_id in READINGS, claim_id
        if CLAIMS[claim_id].parts:   # an exact rule (EMG-1) names its parts as it decides
            assert set(READINGS[claim_id]) == {p.name for p in CLAIMS[claim_id].parts}
    assert set(READINGS) == set(FAMILIES)


def test_no_part_is_gated_on_the_quantity_it_compares() -> None:
    """A property a part reads is never what the part compares (``model_gates.COMPARED``):
    a gate there would decide the part by its outcome."""
    measures = {g.metric: g.measures for gates in GATES.values() for g in gates}
    for claim_id, part, reading in _model_parts():
        needs = next((p.needs for p in CLAIMS[claim_id].parts if p.name == part), ())
        compared = {COMPARED[n] for n in needs if n in COMPARED}
        read = {measures[m] for m in reading.properties}
        assert not compared & read, (claim_id, part, compared & read)


def test_the_table_lists_every_arm_with_what_gates_it() -> None:
    rows = gate_table(READINGS)
    assert {(r["claim"], r["part"]) for r in rows} == {(c, p) for c, p, _ in _model_parts()}
    for row in rows:
        reading = READINGS[row["claim"]][row["part"]]
        if row["role"] == WORSE:
            assert row["gated_on"] == list(TRAINING_GATES)
        elif row["role"] == COMMON:
            assert row["gated_on"] == []
        else:
            assert row["gated_on"] == list(reading.properties)


@pytest.mark.parametrize(("claim_id", "part", "reading"), _model_parts(),
                         ids=[f"{c}:{p}" for c, p, _ in _model_parts()])
def test_a_gate_holds_back_a_part_only_on_what_it_reads(claim_id: str, part: str,
                                                         reading: Reading) -> None:
    records = _records(claim_id, reading)
    gating = held_back({part: reading}, records, [part])
    assert violations(held_back, {part: reading}, records, [part]) == []
    for record in records:
        entry = gating[record["name"]]
        if record["arm"] is None and len(reading.arms) > 1:   # shared: reported, not gating
            assert not entry["holds_back"] and entry["common"] == {
                part: [g.metric for g in GATES[record["family"]]]}
        elif record["arm"] in reading.worse:                  # gated on training alone
            assert entry["holds_back"] == {part: list(TRAINING_GATES)}
        else:
            family = {g.metric for g in GATES[record["family"]]}
            read = [m for m in reading.properties if m in family]
            assert entry["holds_back"] == ({part: read} if read else {})


def test_the_check_fails_on_gates_version_4() -> None:
    """The same table against version 4's gating: a shared decoder's foot skating, the ε
    trajectory model's root jerk and the worse arm's sample gates all held parts back."""
    found = []
    for claim_id, part, reading in _model_parts():
        records = _records(claim_id, reading)
        found += violations(_v4, {part: reading}, records, [part])
    assert any("EMG-2" not in f and "shared" in f and "foot_skating" in f for f in found)
    assert any("root_jerk" in f for f in found)
    assert any("gmd_motion eps" in f and "joint_jerk" in f for f in found)


def test_a_worse_arm_trained_for_fewer_steps_is_held_back() -> None:
    reading = READINGS["GMD-A3"]["eps_reaches_goal_better"]
    passing = {m: {"passed": True} for m in ("training_plateau", "x0_error_vs_gaussian",
                                             "path_length", "root_jerk")}
    eps = {"name": "eps", "family": "gmd_trajectory", "arm": "eps", "gate": passing,
           "passed": True, "reads": None, "steps": 1000}
    x0 = {**eps, "name": "x0", "arm": "x0", "steps": 500}
    gating = held_back({"eps_reaches_goal_better": reading}, [eps, x0],
                       ["eps_reaches_goal_better"])
    assert gating["x0"]["holds_back"] == {"eps_reaches_goal_better": ["steps"]}
    assert gating["eps"]["holds_back"] == {}
    with pytest.raises(ValueError, match="none of the part's arms"):
        held_back({"eps_reaches_goal_better": reading}, [{**eps, "arm": "relative"}],
                  ["eps_reaches_goal_better"])


def test_a_part_that_compares_one_arm_does_not_read_the_other_arms_models() -> None:
    readings = READINGS["GMD-B2"]
    parts = list(readings)
    passing = {m: {"passed": True} for m in ("training_plateau", "x0_error_vs_gaussian")}
    relative = {"name": "rel", "family": "gmd_trajectory", "arm": "relative",
                "gate": {**passing, "path_length": {"passed": False}}, "passed": False,
                "reads": None, "steps": 1000}
    absolute = {**relative, "name": "abs", "arm": "absolute"}
    gating = held_back(readings, [relative, absolute], parts)
    assert "abs_imputation_below_10cm" not in gating["rel"]["holds_back"]
    assert gating["abs"]["holds_back"]["abs_imputation_below_10cm"] == ["path_length"]
    assert gating["rel"]["holds_back"] == {}          # the worse arm: its training alone
