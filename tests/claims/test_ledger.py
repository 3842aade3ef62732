"""The ledger: the registry's rule, controls decided by the same rule, fitness gates that make
inconclusive the parts that read their model, and what the sidecar keeps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import make_context, run_settings

from repro.claims.ledger import load_sidecars, record_claim, verdict_markdown
from repro.claims.registry import REGISTRY_VERSION, get_claim
from repro.claims.verdicts import INCONCLUSIVE, PARTIAL, REPRODUCED, SUPPORTED

A3_RUN = run_settings("GMD-A3")
A4_RUN = run_settings("GMD-A4")

A3_GOOD = {"goal_error_x0": [0.5, 0.6, 0.55, 0.52, 0.58],
           "goal_error_eps": [0.1, 0.12, 0.11, 0.1, 0.13],
           "best_gain_survival_eps": [0.9, 0.95, 0.92, 0.93, 0.91],
           "guided_change_survival_eps": [0.9, 0.95, 0.92, 0.93, 0.91],
           "best_gain_survival_x0": [0.3, 0.2, 0.25, 0.22, 0.28],
           "guided_change_survival_x0": [0.3, 0.2, 0.25, 0.22, 0.28]}


def test_sidecar_carries_parts_with_what_the_run_could_see_and_missing_controls(
        tmp_path: Path) -> None:
    decision = record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", A3_GOOD,
                            settings=A3_RUN, seeds=[0, 1, 2, 3, 4])
    sidecar = load_sidecars(tmp_path / "claims")["GMD-A3"]
    assert sidecar["registry_version"] == REGISTRY_VERSION == 12
    assert sidecar["verdict"] == decision.verdict == REPRODUCED
    assert "v1" not in sidecar and "power_note" not in sidecar
    assert [p["name"] for p in sidecar["parts"]] == ["eps_reaches_goal_better",
                                                     "eps_keeps_more_of_best_gain"]
    numbers = sidecar["parts"][0]["numbers"]["difference"]
    assert numbers["n"] == 5 and numbers["minimum_detectable_effect"] > 0
    assert sidecar["controls"]["positive"]["status"] == "missing"
    assert sidecar["controls"]["null"]["status"] == "missing"
    text = verdict_markdown(make_context(tmp_path, scale="standard"), "GMD-A3", decision,
                            sidecar["rule"])
    assert "registry v12" in text and "**GMD-A3 — reproduced**" in text
    assert sidecar["rule"] in text and "T = 100 cosine" in sidecar["rule"]
    assert sidecar["settings"] == {**A3_RUN, "seeds": 5}


def test_controls_are_decided_by_the_same_rule(tmp_path: Path) -> None:
    claim, rng = get_claim("GMD-A3"), np.random.default_rng(3)
    ctx = make_context(tmp_path, scale="standard")
    planted, null = claim.planted_example(rng), claim.null_example(rng)
    seeds = list(range(len(planted["goal_error_x0"])))
    decision = record_claim(ctx, "GMD-A3", planted, settings=A3_RUN, seeds=seeds,
                            controls={"positive": planted, "null": null})
    assert decision.verdict == REPRODUCED
    stored = load_sidecars(tmp_path / "claims")["GMD-A3"]["controls"]
    assert stored["positive"]["status"] == "passed" and stored["null"]["status"] == "passed"
    # a positive control that shows nothing: the significant parts stand ...
    failed = record_claim(ctx, "GMD-A3", planted, settings=A3_RUN, seeds=seeds,
                          controls={"positive": null, "null": null})
    assert failed.verdict == REPRODUCED and "failed positive control" in failed.reason
    # ... and the parts that were not significant become inconclusive, saying why
    undecided = record_claim(ctx, "GMD-A3", null, settings=A3_RUN, seeds=seeds,
                             controls={"positive": null, "null": null})
    assert undecided.verdict == INCONCLUSIVE
    assert all("positive control missed" in p.reason for p in undecided.parts
               if p.outcome == INCONCLUSIVE)
    assert {p.outcome for p in undecided.parts} <= {INCONCLUSIVE, "contradicted"}
    # a null control that fires
    fired = record_claim(ctx, "GMD-A3", planted, settings=A3_RUN,
                         seeds=[0], controls={"null": planted})
    assert fired.verdict == INCONCLUSIVE and "null control fired" in fired.reason
    stored = load_sidecars(tmp_path / "claims")["GMD-A3"]["controls"]
    assert stored["null"]["status"] == "failed" and stored["positive"]["status"] == "missing"
    with pytest.raises(ValueError, match="controls are"):
        record_claim(ctx, "GMD-A3", planted, settings=A3_RUN, seeds=[0],
                     controls={"oracle": planted})


def test_quality_gate_and_new_measurements(tmp_path: Path) -> None:
    ctx = make_context(tmp_path)
    gated = record_claim(ctx, "GMD-A3", A3_GOOD, settings=A3_RUN, seeds=[0],
                         quality_gates={"x0_model_fid": False})
    assert gated.verdict == INCONCLUSIVE and "x0_model_fid" in gated.reason
    # a measurement only later versions read, not recorded: inconclusive, not an error
    emg9 = record_claim(ctx, "EMG-9", {"fid_vs_closed_form_relative_error": 1e-15,
                                       "printed_vs_closed_form_relative_error": 0.15},
                        seeds=[0])
    assert emg9.verdict == INCONCLUSIVE and "not recorded" in emg9.reason
    with pytest.raises(ValueError, match="printed_vs_closed_form_relative_error"):
        record_claim(ctx, "EMG-9", {"fid_vs_closed_form_relative_error": 0.0}, seeds=[0])


def test_a_model_that_fails_a_gate_a_part_reads_makes_that_part_inconclusive(
        tmp_path: Path) -> None:
    from conftest import make_context

    from repro.claims.report import models_markdown, models_of
    from repro.core.gates import model_record
    from repro.infra.storage import read_json

    claim = get_claim("GMD-A4")
    measured = claim.planted_example(np.random.default_rng(0))
    data = {"joint_speed": 1.0, "root_speed": 1.0, "joint_jerk": 100.0, "foot_skating": 0.05,
            "concept_recall": 0.8}
    moving = {**data, "x0_error_vs_gaussian": 0.5, "training_plateau": 0.0}
    curve = [1.0] * 10

    def motion(name: str, arm: str, **values: float) -> dict:
        return model_record(name=name, family="gmd_motion", role="reference", arm=arm,
                            values={**moving, **values}, reference=data, steps=4500,
                            validation_curve=curve)

    good = motion("x0 motion", "x0")
    ctx = make_context(tmp_path, scale="standard")
    passed = record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                          models=[good])
    assert passed.verdict == "reproduced"
    # the x0 arm stands still: every part reads its movement
    still = motion("x0 motion still", "x0", joint_speed=0.1)
    failed = record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                          models=[still])
    assert failed.verdict == "inconclusive" and "model x0 motion still" in failed.reason
    assert "joint_speed" in failed.parts[0].reason
    # jagged x0 samples: only the FID part reads jerk (the jagged part compares it)
    jagged = motion("x0 motion jagged", "x0", joint_jerk=900.0)
    partial = record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                           models=[jagged])
    assert partial.verdict == PARTIAL
    assert partial.checks == {"eps_motion_more_jagged": SUPPORTED,
                              "eps_motion_worse_fid": INCONCLUSIVE,
                              "choice_matters_less_for_trajectories": SUPPORTED}
    # the ε arm, predicted worse, is gated on its training alone: jagged samples gate nothing,
    # a loss still falling (or fewer steps than the x0 arm's) holds its parts back
    eps_jagged = motion("eps motion jagged", "eps", joint_jerk=900.0, joint_speed=0.1)
    assert record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                        models=[good, eps_jagged]).verdict == "reproduced"
    falling = motion("eps motion falling", "eps", training_plateau=0.3)
    assert record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                        models=[good, falling]).verdict == "inconclusive"
    short = dict(motion("eps motion short", "eps"), steps=900)
    assert record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                        models=[good, short]).verdict == "inconclusive"
    # an evaluator both arms share is common-mode: reported beside the FID part, not gating
    blind = model_record(name="eps motion", family="evaluator", role="reference",
                         values={"r_precision_top3": 0.2})
    shared = record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                          models=[good, blind])
    assert shared.verdict == "reproduced"
    assert "reported, not gating: eps motion fails r_precision_top3" in shared.parts[1].reason
    with pytest.raises(ValueError, match="reads parts"):
        record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                     models=[dict(blind, reads=["no_such_part"])])
    sidecars = {"GMD-A4": read_json(tmp_path / "claims" / "GMD-A4.json")}
    models = models_of(sidecars)
    assert [m["name"] for m in models] == ["eps motion", "x0 motion"]
    assert models[0]["claims"] == ["GMD-A4"] and not models[0]["passed"]
    assert "**no**" in "\n".join(models_markdown(models))
    with pytest.raises(ValueError, match="model_record"):
        record_claim(ctx, "GMD-A4", measured, settings=A4_RUN, seeds=[0, 1, 2],
                     models=[{"name": "x"}])
