"""GMD-C4's readings and ClaimResult (notebook 03; issue #34) from a ``Results`` with known
per-seed skating and κ (no models)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from gmd.test_emphasis_study import _fake_results

from repro.claims.result import Controls
from repro.gmd import emphasis_projection
from repro.gmd.emphasis_projection import ProjectionSettings, Settings


def test_spectra_count_the_drowned_directions_per_seed() -> None:
    results = _fake_results()
    results.models["Emphasis c=10"] = SimpleNamespace(
        diffusion=SimpleNamespace(alphas_cumprod=[0.999]))
    settings = Settings.for_scale("paper")
    spectra = emphasis_projection.spectra(results, settings, results.seeds, seed=0)
    assert spectra.alpha_bar_last == pytest.approx(0.999)
    assert set(spectra.drowned) == {"2", "10"} and len(spectra.drowned["10"]) == 4
    assert "| 10 | 100, 200, 300, 400 |" in spectra.markdown


def test_c4_result_records_the_rules_lists_and_the_readings() -> None:
    results = _fake_results()
    settings = Settings.for_scale("paper")
    kappa = emphasis_projection.kappa_reading(results)
    assert kappa.relation["10"]["rho"] == pytest.approx(1.0)
    assert "κ 100–400" in kappa.markdown
    spectra = emphasis_projection.Spectra(0.99, {"2": [0] * 4, "10": [1] * 4}, "")
    controls = Controls(null={}, positive={}, planted={"foot_skating_factor_loss_scaling": 1.1})
    result = emphasis_projection.c4_result(results, settings, settings.base_spec(), results.seeds,
                                   controls=controls, spectra=spectra, kappa=kappa,
                                   model_records=[], outside_records=[{"name": "orthogonal",
                                                                       "passed": True}])
    assert result.claim_id == "GMD-C4" and result.controls is controls
    assert result.measured["values"] == [2, 10]
    assert result.measured["foot_skating_emphasis"]["10"] == [1.0, 2.0, 3.0, 4.0]
    assert result.headline.startswith("foot skating (loss k − Emphasis c, m/s): v=2: ")
    assert result.extra["condition_number"]["gaussian"]["10"] == [100.0, 200.0, 300.0, 400.0]
    assert result.extra["outside_rule_gates"] == {"orthogonal": True}
    assert result.extra["controls_planted"] == controls.planted


def test_setup_summary_and_table_b1_name_what_the_scale_leaves_out() -> None:
    standard = Settings.for_scale("standard")
    text = emphasis_projection.setup_summary(standard, ProjectionSettings.for_scale("standard"),
                                             [0], scale="standard", threads=1)
    assert text.splitlines()[2] == "seeds: [0] | torch threads: 1"
    assert "not run at the standard scale: " in text
    assert "not run" not in emphasis_projection.setup_summary(
        Settings.for_scale("paper"), ProjectionSettings.for_scale("paper"), [0],
        scale="paper", threads=1)
    assert emphasis_projection.table_b1_markdown(None, None, standard, [0], seed=0).startswith(
        "*Table B.1 is not run at the standard scale")
