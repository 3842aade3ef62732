"""Notebook 01's results (``gmd.x0_vs_eps_results``): what GMD-A1…A4 record, built from the
measurements, and the per-seed views of the A3 study."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from conftest import make_context

from repro.claims.registry import get_claim
from repro.claims.result import record
from repro.claims.verdicts import PAPER_DISCREPANCY, REPRODUCED
from repro.gmd import models
from repro.gmd import x0_vs_eps as x0_vs_eps_results
from repro.gmd.x0_vs_eps import A3Study, a1_result, a2_result, finite

#: what every sidecar of notebook 01 records under ``extra["parameters"]`` (issue #17)
KEYS = {"num_timesteps", "guidance_stop_t", "x0_clamp"}


def test_a1_and_a2_record_the_registered_measurements_and_the_parameters(
        tmp_path: Path) -> None:
    cosine = models.schedule_diffusion("cosine", 1000)
    mu_difference = x0_vs_eps_results.posterior_mean_forms(cosine, samples=4, seed=0)
    printed = x0_vs_eps_results.printed_c_relative_error(cosine)
    a1 = a1_result(cosine, mu_difference, printed, figure=tmp_path / "a1.png", seed=0)
    assert set(get_claim("GMD-A1").measurements) <= set(a1.measured)
    assert set(a1.extra["parameters"]) == KEYS
    assert a1.extra["c_equals_one_over_sqrt_alpha_max_error"] == x0_vs_eps_results.c_identity_error(
        cosine) < 1e-9
    schedules = {name: x0_vs_eps_results.coefficient_shares(models.schedule_diffusion(name))
                 for name in ("cosine", "linear")}
    peaks = {name: {k: x0_vs_eps_results.peak_fraction(v[k]) for k in ("x0_share", "eps_share")}
             for name, v in schedules.items()}
    a2 = a2_result(schedules, peaks, figure=tmp_path / "a2.png", seed=0)
    assert a2.extra["parameters"] == {"num_timesteps": 1000, "guidance_stop_t": None,
                                      "x0_clamp": None}
    assert a2.headline.startswith("cosine: x0 share a/(a+b) peaks at t = 1/1000")
    assert set(a2.extra["cosine_x0_share_at"]) == {"1", "10", "500", "1000"}
    ctx = make_context(tmp_path, scale="standard")
    assert record(ctx, a1).verdict == PAPER_DISCREPANCY  # the printed Eq. 2 drops a square root
    assert record(ctx, a2).verdict == REPRODUCED


def test_every_result_of_notebook_01_records_the_guidance_parameters() -> None:
    tree = ast.parse(inspect.getsource(x0_vs_eps_results))
    calls = [node for node in ast.walk(tree) if isinstance(node, ast.Call)
             and getattr(node.func, "id", None) == "ClaimResult"]
    assert len(calls) == 4
    for call in calls:
        extra = next(k.value for k in call.keywords if k.arg == "extra")
        assert isinstance(extra, ast.Dict)
        keys = {k.value for k in extra.keys if isinstance(k, ast.Constant)}
        assert "parameters" in keys, ast.unparse(call)[:80]


def test_the_a3_study_reads_each_seed_in_order() -> None:
    def run(offset: float) -> SimpleNamespace:
        return SimpleNamespace(error_guided=np.array([offset, offset + 1.0]),
                               error_unguided=np.array([2.0, 4.0]), best_step=int(offset),
                               survival=offset / 10, stop_step_survival=float("nan"))

    study = A3Study({(p, s): run(s + (p == "epsilon")) for p in ("x0", "epsilon")
                     for s in (3, 1)}, [1, 3], {"num_timesteps": 10})
    assert study.goal_error == {"x0": [1.5, 3.5], "epsilon": [2.5, 4.5]}
    assert study.seed_means("x0", "error_unguided") == [3.0, 3.0]
    assert study.per_seed("epsilon", "best_step") == [2.0, 4.0]
    assert study.survival["x0"] == [0.1, 0.3]
    assert finite(study.stop_survival["x0"]) == [None, None]
