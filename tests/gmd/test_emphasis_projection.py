"""Emphasis models over repro.gmd: projected feature space, x̂0 imputation, coherence measures."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
import torch
from torch import nn

from repro.claims.result import Controls
from repro.gmd.emphasis_projection import c1, c2, c3, c4, experiment
from repro.gmd.emphasis_projection.experiment import (
    ImputedX0,
    ProjectedFeatureSpace,
    Settings,
    Variant,
    coherence,
    draw_targets,
    project_windows,
    root_velocity_disagreement,
    trajectory_error,
)
from repro.gmd.emphasis_projection.projection import EmphasisProjection, ProjectionSettings
from repro.gmd.models import GMDModelSpec
from repro.gmd.windows import DataConfig, MotionWindows, load_windows
from repro.infra.paths import data_stubs_dir

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def windows() -> MotionWindows:
    config = DataConfig(data_dir=str(data_stubs_dir()), frames=32, stride=32)
    return load_windows(config)


def _projected_space(windows: MotionWindows, c: float = 10.0) -> ProjectedFeatureSpace:
    space = windows.space("motion")
    return ProjectedFeatureSpace(space.task, space.representation, space.mean, space.std,
                                 EmphasisProjection(c=c, seed=3))


def test_projected_space_recovers_the_same_motion(windows: MotionWindows) -> None:
    plain = windows.space("motion")
    projected = _projected_space(windows)
    x = windows.x[:4].double()
    y = projected.projection.project_channels_first(x)
    torch.testing.assert_close(projected.unnormalise(y), plain.unnormalise(x), rtol=1e-9,
                               atol=1e-9)
    torch.testing.assert_close(projected.normalise(plain.unnormalise(x)), y, rtol=1e-9,
                               atol=1e-9)
    torch.testing.assert_close(projected.joints(y), plain.joints(x), rtol=1e-9, atol=1e-9)


def test_project_windows_changes_data_and_fingerprint(windows: MotionWindows) -> None:
    projection = EmphasisProjection(c=5.0, seed=1)
    projected = project_windows(windows, projection)
    assert projected.fingerprint != windows.fingerprint
    assert projected.x.dtype == torch.float32 and projected.x.shape == windows.x.shape
    torch.testing.assert_close(projected.x, projection.project_channels_first(windows.x))
    other = project_windows(windows, EmphasisProjection(c=5.0, seed=2))
    assert other.fingerprint != projected.fingerprint


class _Constant(nn.Module):
    def __init__(self, value: torch.Tensor) -> None:
        super().__init__()
        self.value = value

    def forward(self, x_t: torch.Tensor, t: torch.Tensor, **_: object) -> torch.Tensor:
        return self.value.expand_as(x_t).clone()


def test_imputed_x0_overwrites_root_in_unprojected_space(windows: MotionWindows) -> None:
    space = _projected_space(windows)
    x = windows.x[:2].double()
    prediction = space.projection.project_channels_first(torch.zeros_like(x))
    mask = torch.zeros_like(x, dtype=torch.bool)
    mask[:, [1, 2]] = True
    wrapper = ImputedX0(_Constant(prediction), space, mask, x, stop=5)
    out = wrapper(prediction, torch.full((2,), 7))
    back = space.projection.unproject_channels_first(out)
    torch.testing.assert_close(back[:, [1, 2]], x[:, [1, 2]], rtol=1e-9, atol=1e-9)
    assert back[:, 3:].abs().max() < 1e-9
    untouched = wrapper(prediction, torch.full((2,), 4))
    torch.testing.assert_close(untouched, prediction)


def test_root_velocity_disagreement_is_zero_on_data(windows: MotionWindows) -> None:
    features = windows.features()
    assert root_velocity_disagreement(features).max() < 1e-4
    shifted = features.clone()
    shifted[:, 10:, 1] += 0.5  # the root jumps 0.5 m; the velocity features do not
    assert root_velocity_disagreement(shifted).max() > 0.2


def test_coherence_and_trajectory_error_of_ground_truth(windows: MotionWindows) -> None:
    targets = draw_targets(windows, 8, seed=0)
    space = windows.space("motion")
    measured = coherence(space, targets.x)
    assert set(measured) == {"foot_skating", "foot_skating_ratio", "root_velocity_disagreement",
                             "acceleration", "jerk"}
    assert measured["root_velocity_disagreement"] < 1e-4
    np.testing.assert_allclose(trajectory_error(space, targets.x, targets.xz), 0.0, atol=1e-6)
    assert targets.relative.shape == (8, 32, 263)


def test_variants_follow_gmds_configs() -> None:
    base = GMDModelSpec(task="motion", prediction="x0")
    loss = Variant("loss_scaling", 10).spec(base, seed=4)
    assert loss.training.seed == 4
    assert loss.training.feature_weights[:5] == (100.0, 100.0, 100.0, 100.0, 1.0)
    assert Variant("loss_scaling", 1).spec(base, seed=4).training.feature_weights is None
    assert Variant("loss_scaling", 2).projection(seed=0) is None
    emphasis = Variant("emphasis", 5)
    assert emphasis.spec(base, seed=2).training.feature_weights is None
    projection = emphasis.projection(seed=2)
    assert projection.c == 5.0 and projection.seed == 2 and projection.emphasised == (0, 1, 2)
    assert emphasis.label == "Emphasis c=5"
    with pytest.raises(ValueError):
        Variant("both", 2)  # type: ignore[arg-type]


def test_projection_settings_shrink_in_quick_mode() -> None:
    from repro.gmd.emphasis_projection.projection import ProjectionSettings

    quick, full = ProjectionSettings.for_scale("quick"), ProjectionSettings.for_scale("paper")
    assert full.simulation_samples == 10000 and full.kappa_scan_seeds == 20
    assert all(getattr(quick, f) < getattr(full, f) for f in vars(full))


def test_c4_settings_follow_the_registry_and_the_run_seeds() -> None:
    from repro.claims.registry import get_claim
    from repro.gmd.emphasis_projection.experiment import TABLE_B1_VARIANTS, Settings
    from repro.gmd.settings import FULL_SEEDS

    claim = get_claim("GMD-C4")
    full, quick = Settings.for_scale("paper"), Settings.for_scale("quick")
    assert [f"{v:g}" for v in full.values] == [p.name.rsplit("_", 1)[1] for p in claim.parts]
    assert full.seeds == FULL_SEEDS["GMD-C4"] and quick.seeds == 1
    assert all(v.in_rule for v in full.variants()) and len(full.variants()) == 4
    outside = full.outside_rule_variants()
    assert {v.label for v in outside} == {"Emphasis c=10 (orthogonal)",
                                          "Emphasis c=10 (GMD float32)", "loss scaling k=1"}
    assert not any(v.in_rule for v in outside if v.method == "emphasis")
    assert set(TABLE_B1_VARIANTS) <= set(full.variants() + outside)
    assert full.trained_models == 6 * 6  # the GMD float32 arm trains no model of its own
    # quick mode runs every code path, small (a test of the code, never a result)
    assert quick.values == full.values and quick.seeds == 1 and quick.train_steps <= 10
    assert quick.samples < full.samples and quick.stand_in_clips < full.stand_in_clips


def test_sensitivity_variants_build_their_matrices() -> None:
    orthogonal = Variant("emphasis", 10, kind="orthogonal")
    assert orthogonal.projection(seed=2).kind == "orthogonal" and not orthogonal.in_rule
    gmd = Variant("emphasis", 10, precision="float32_gmd")
    assert gmd.projection(seed=2).precision == "float32_gmd" and gmd.label.endswith("float32)")
    assert Variant("emphasis", 10) == Variant("emphasis", 10, "gaussian", "float64")
    with pytest.raises(ValueError):
        Variant("loss_scaling", 2, kind="orthogonal")


def test_gmd_float32_arm_samples_the_gaussian_arms_model(windows: MotionWindows,
                                                         monkeypatch) -> None:
    """GMD's float32 construction loads the Gaussian arm's model (same training data) and
    samples it through GMD's float32 P and P⁻¹; the orthogonal arm trains on its own data."""
    import dataclasses

    @dataclasses.dataclass
    class Loaded:
        space: object

    trained_on = []

    def fake_load_or_train(spec, data, device="cpu"):
        trained_on.append(data.fingerprint)
        return Loaded(windows.space("motion"))

    monkeypatch.setattr(experiment, "load_or_train_gmd", fake_load_or_train)
    base = GMDModelSpec(task="motion", prediction="x0")
    arms = [Variant("emphasis", 10), Variant("emphasis", 10, precision="float32_gmd"),
            Variant("emphasis", 10, kind="orthogonal")]
    loaded = [experiment.load_or_train_variant(base, v, windows, 1) for v in arms]
    assert trained_on[0] == trained_on[1] != trained_on[2]
    assert [m.space.projection.precision for m in loaded] == ["float64", "float32_gmd",
                                                              "float64"]
    assert loaded[2].space.projection.kind == "orthogonal"


def _fake_results(seeds: int = 4):
    """A ``Results`` with known per-seed skating and κ (no models)."""
    from repro.gmd.emphasis_projection.experiment import Results, Settings

    settings = Settings.for_scale("paper")
    variants, outside = settings.variants(), settings.outside_rule_variants()
    kappa = [100.0 * (i + 1) for i in range(seeds)]
    imputed, kappas = {}, {}
    for v in variants + outside:
        if v.method == "loss_scaling":
            skating = [1.0 + 0.01 * i for i in range(seeds)]
        elif v.kind == "orthogonal":
            skating = [0.5] * seeds
        else:  # skating grows with κ; GMD's float32 arm skates 0.1 m/s more
            skating = [k / 100.0 + (0.1 if v.precision == "float32_gmd" else 0.0) for k in kappa]
        imputed[v.label] = {"foot_skating": skating}
        if v.method == "emphasis":
            kappas[v.label] = [v.value] * seeds if v.kind == "orthogonal" else kappa
    return Results(list(range(seeds)), variants, imputed, {}, {"foot_skating": [0.05] * seeds},
                   {}, None, {v.label: [1.0] * seeds for v in variants + outside}, {},
                   outside_rule=outside, condition_numbers=kappas)


def test_kappa_relation_and_outside_rule_summary() -> None:
    from repro.gmd.emphasis_projection.c4 import kappa_skating_relation, outside_rule_summary

    results = _fake_results()
    relation = kappa_skating_relation(results)
    assert set(relation) == {"2", "10"}
    assert relation["10"]["rho"] == pytest.approx(1.0) and relation["10"]["n"] == 4
    assert kappa_skating_relation(_fake_results(seeds=2))["2"]["rho"] is None
    summary = outside_rule_summary(results)
    assert set(summary) == {"Emphasis c=10 (orthogonal)", "Emphasis c=10 (GMD float32)"}
    gmd = summary["Emphasis c=10 (GMD float32)"]
    assert gmd["arm_minus_gaussian"]["mean"] == pytest.approx(0.1)
    orthogonal = summary["Emphasis c=10 (orthogonal)"]
    assert orthogonal["condition_number"] == [10] * 4
    assert orthogonal["loss_scaling_minus_arm"]["mean"] == pytest.approx(1.015 - 0.5)
    assert results.kappa_per_value()["10"] == [100.0, 200.0, 300.0, 400.0]
    assert set(results.per_value("emphasis", "foot_skating")) == {"2", "10"}


def test_skating_against_kappa_figure() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from repro.gmd.emphasis_projection.c4 import plot_skating_against_kappa

    fig = plot_skating_against_kappa(_fake_results())
    ax = fig.axes[0]
    # the four Emphasis arms, loss scaling at k = c, the data and GMD's released κ
    assert ax.get_xscale() == "log" and len(ax.get_lines()) == 4 + 2 + 2
    plt.close(fig)


# ------------------------------------------------------------------------------------------------
# GMD-C1…C3 as experiments that return their measurements and their ClaimResults
# (notebook 03): Eq. 4's c*, the inverse's errors and the variance factors.
# ------------------------------------------------------------------------------------------------

#: tiny sample sizes: a test of the code, never a result
CHECKS = ProjectionSettings(simulation_samples=400, distance_pairs=200, inverse_frames=50,
                            kappa_scan_seeds=2, kappa_scan_frames=20)


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    return np.random.default_rng(0).standard_normal((120, 263))


def test_c1_finds_c_star_and_records_the_rules_inputs(frames: np.ndarray) -> None:
    check = c1.relative_importance_check(frames, [0], CHECKS, seed=0)
    assert check.c_star == pytest.approx(math.sqrt(260 / 3))
    assert check.importance_at_c_star == pytest.approx(0.5)
    assert len(check.simulated) == len(c1.C1_GRID) and check.simulation_error < 0.1
    result = c1.c1_result(check, seed=0, figures=["c1.png"])
    assert result.claim_id == "GMD-C1" and result.seeds == [0]
    assert result.measured == {"simulation_max_abs_error": check.simulation_error,
                               "c_star": check.c_star,
                               "importance_at_c_star": check.importance_at_c_star}
    assert result.extra["projected_gaussian"].keys() == {"0"}
    assert "c* = √(260/3) = 9.309" in result.headline and "I = ½" in check.summary()


def test_c2_measures_distances_at_c1_and_the_inverse_at_c10(frames: np.ndarray) -> None:
    check = c2.distance_inverse_check(frames, [0, 1], CHECKS, seed=0)
    assert set(check.ratios) == {(1.0, 0), (1.0, 1), (10.0, 0), (10.0, 1)}
    assert check.fraction_within == min(check.within[(1.0, 0)], check.within[(1.0, 1)])
    assert check.inverse64 < check.inverse32 and check.inverse_frames == 50
    result = c2.c2_result(check)
    assert result.seeds == [0, 1] and result.measured["inverse_relative_error_float32"] == (
        check.inverse32)
    assert set(result.extra["within_20_percent"]) == {"c=1,seed=0", "c=1,seed=1",
                                                      "c=10,seed=0", "c=10,seed=1"}
    assert len(check.summary().splitlines()) == 4


def test_c2_float32_part_does_not_turn_on_the_matrix_drawn(frames: np.ndarray) -> None:
    """Registry v9: each matrix's float32 round trip against (2 + 2√n)·κ(P)·u. Over matrix
    seeds whose κ spans 1.7·10³–1.4·10⁶ (the old fixed 1e-4 failed 14 of 40) the part holds;
    a wrong inverse (Pᵀ's, or P⁻¹ off by 10⁻³ relative) fails it at the same κ."""
    from repro.claims.registry import CLAIMS
    from repro.claims.registry_gmd import float32_round_trip_bound

    check = c2.distance_inverse_check(frames, list(range(12)), CHECKS, seed=0)
    measured = c2.c2_result(check).measured
    assert max(check.kappa[(10.0, s)] for s in range(12)) > 1e5
    assert 0 < measured["inverse_float32_error_over_bound"] <= 1.0
    assert measured["inverse_relative_error_float32"] > 1e-4   # the v8 bound would fail
    assert CLAIMS["GMD-C2"].decide(measured).checks["inverse_float32_within_its_bound"] == (
        "supported")
    projection = EmphasisProjection(c=10.0, seed=0)
    x = torch.from_numpy(frames).to(torch.float32)
    bound = float32_round_trip_bound(projection.condition_number)
    for wrong in (projection.matrix.T, projection.inverse * (1 + 1e-3 * torch.randn(
            projection.inverse.shape, generator=torch.Generator().manual_seed(0),
            dtype=torch.float64))):
        back = (x @ projection.matrix.to(torch.float32)) @ wrong.to(torch.float32)
        error = float(((back - x).norm(dim=1) / x.norm(dim=1)).max())
        failing = dict(measured, inverse_float32_error_over_bound=error / bound)
        assert CLAIMS["GMD-C2"].decide(failing).checks[
            "inverse_float32_within_its_bound"] != "supported"


def test_c3_the_printed_factor_leaves_a_tiny_variance(frames: np.ndarray) -> None:
    check = c3.unit_variance_check(frames, CHECKS, seed=0)
    assert check.variance_printed == pytest.approx(1 / 560, rel=0.2)
    assert check.variance_sqrt == pytest.approx(1.0, rel=0.2)
    result = c3.c3_result(check)
    assert result.seeds == [0] and result.measured == {
        "variance_with_printed_factor": check.variance_printed,
        "variance_with_sqrt_factor": check.variance_sqrt}
    assert result.extra["c_grid"] == list(map(float, c3.C3_GRID))


# ------------------------------------------------------------------------------------------------
# GMD-C4's readings and ClaimResult (notebook 03) from a ``Results`` with known
# per-seed skating and κ (no models).
# ------------------------------------------------------------------------------------------------

def test_spectra_count_the_drowned_directions_per_seed() -> None:
    results = _fake_results()
    results.models["Emphasis c=10"] = SimpleNamespace(
        diffusion=SimpleNamespace(alphas_cumprod=[0.999]))
    settings = Settings.for_scale("paper")
    spectra = c4.spectra(results, settings, results.seeds, seed=0)
    assert spectra.alpha_bar_last == pytest.approx(0.999)
    assert set(spectra.drowned) == {"2", "10"} and len(spectra.drowned["10"]) == 4
    assert "| 10 | 100, 200, 300, 400 |" in spectra.markdown


def test_c4_result_records_the_rules_lists_and_the_readings() -> None:
    results = _fake_results()
    settings = Settings.for_scale("paper")
    kappa = c4.kappa_reading(results)
    assert kappa.relation["10"]["rho"] == pytest.approx(1.0)
    assert "κ 100–400" in kappa.markdown
    spectra = c4.Spectra(0.99, {"2": [0] * 4, "10": [1] * 4}, "")
    controls = Controls(null={}, positive={}, planted={"foot_skating_factor_loss_scaling": 1.1})
    result = c4.c4_result(results, settings, settings.base_spec(), results.seeds,
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
    text = experiment.setup_summary(standard, ProjectionSettings.for_scale("standard"),
                                    [0], scale="standard", threads=1)
    assert text.splitlines()[2] == "seeds: [0] | torch threads: 1"
    assert "not run at the standard scale: " in text
    assert "not run" not in experiment.setup_summary(
        Settings.for_scale("paper"), ProjectionSettings.for_scale("paper"), [0],
        scale="paper", threads=1)
    assert c4.table_b1_markdown(None, None, standard, [0], seed=0).startswith(
        "*Table B.1 is not run at the standard scale")


# ------------------------------------------------------------------------------------------------
# Notebook 03's figures draw from measured values alone (smoke tests on small inputs).
# ------------------------------------------------------------------------------------------------

matplotlib.use("Agg")


def test_emphasis_figures() -> None:
    grid = np.array([1.0, 2.0, 10.0])
    share = grid**2 / (grid**2 + 1)
    fig = c1.plot_relative_importance(grid, share, {0: share}, share, share,
                                      c_star=9.3, importance_at_10=0.54,
                                      simulation_error=1e-3)
    assert len(fig.axes) == 1
    spread = np.ones(263)
    fig = c3.plot_unit_variance(grid, 260 + 3 * grid**2,
                                1 / np.sqrt(260 + 3 * grid**2),
                                1 / (260 + 3 * grid**2), spread, spread, spread)
    assert len(fig.axes) == 3
    plt.close("all")


def test_coherence_figure_does_not_depend_on_timings() -> None:
    import dataclasses
    import io

    import matplotlib.pyplot as plt

    from repro.gmd.emphasis_projection.c4 import COHERENCE_PANELS, plot_coherence

    base = _fake_results()
    for arms in base.imputed.values():
        for metric, _ in COHERENCE_PANELS:
            arms.setdefault(metric, list(arms["foot_skating"]))

    def png(seconds: float) -> bytes:
        timed = dataclasses.replace(base, train_seconds={k: [seconds] * len(v) for k, v in
                                                         base.train_seconds.items()})
        fig = plot_coherence(timed, [2.0, 10.0], samples=4)
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=40)
        plt.close(fig)
        return buffer.getvalue()

    assert png(1.0) == png(123.4)
