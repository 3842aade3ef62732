"""Notebook 01's experiment: paired guided/unguided runs, survival, exact x0 and ε models."""

from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from conftest import make_context

from repro.claims.registry import get_claim
from repro.claims.result import record
from repro.claims.verdicts import PAPER_DISCREPANCY, PARTIAL, REPRODUCED
from repro.gmd.guidance import goal_error, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    GUIDANCE_STOP_T,
    GMDModelSpec,
    TrainedGMD,
    load_or_train_gmd,
    schedule_diffusion,
)
from repro.gmd.windows import DataConfig, FeatureSpace, MotionWindows, load_windows
from repro.gmd.x0_vs_eps import a1, a2, a3, a4
from repro.gmd.x0_vs_eps.a1 import a1_result
from repro.gmd.x0_vs_eps.a2 import a2_result
from repro.gmd.x0_vs_eps.a3 import A3Study, finite
from repro.gmd.x0_vs_eps.common import Settings
from repro.gmd.x0_vs_eps.goal_reaching import (
    best_gain_survival,
    goal_error_kept,
    goal_reaching_experiment,
    guided_change_survival,
)
from repro.infra.paths import data_stubs_dir

torch.set_num_threads(1)

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


def test_goal_reaching_experiment_and_measurements(small_spec, cache: Path) -> None:
    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0], [-0.5, 1.5]], dtype=np.float32)
    result = goal_reaching_experiment(trained, targets, seed=0, strength=10.0)
    assert result.guided.shape == (3, 4, FRAMES) and result.stop_guidance_at == 0
    assert result.x0_error_guided.shape == (20, 3) and result.timesteps[0] == 19
    np.testing.assert_allclose(result.error_guided,
                               goal_error(trained, result.guided, targets), rtol=1e-6)
    assert np.isfinite(result.survival) and result.best_step_error >= 0
    jitter = jitter_of(trained, result.unguided)
    assert jitter.acceleration > 0 and jitter.jerk > 0
    # the same seed without guidance is the same sample
    again = sample(trained, 3, seed=0, clip_x0="gmd")
    assert torch.allclose(again, result.unguided)


def test_guided_change_survival_definition(small_spec) -> None:
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    base = torch.randn(3, 4, FRAMES)
    change = torch.zeros_like(base)
    change[:, 1:3] = torch.randn(3, 2, FRAMES)
    survival = guided_change_survival
    assert survival(space, base + change, base, base + change, base) == pytest.approx(1.0)
    assert survival(space, base + change, base, base, base) == pytest.approx(0.0)
    assert survival(space, base + change, base, base + 0.25 * change, base) == pytest.approx(0.25)
    assert np.isnan(survival(space, base, base, base + change, base))
    assert goal_error_kept([3.0, 3.0], [1.0, 1.0], [3.0, 2.0]) == pytest.approx(0.25)
    assert np.isnan(goal_error_kept([1.0], [2.0], [1.5]))


class _ExactGaussianDenoiser(torch.nn.Module):
    """The exact x0 or ε predictor for data ~ N(0, I): x̂0 = √ᾱ x_t, ε̂ = √(1−ᾱ) x_t."""

    def __init__(self, diffusion, prediction: str) -> None:
        super().__init__()
        self.alphas_cumprod = torch.as_tensor(diffusion.alphas_cumprod, dtype=torch.float32)
        self.prediction = prediction
        self.unused = torch.nn.Parameter(torch.zeros(1))

    def forward(self, x, t, **kwargs):
        alpha_bar = self.alphas_cumprod[t].view(-1, 1, 1)
        return (alpha_bar.sqrt() if self.prediction == "x0" else (1 - alpha_bar).sqrt()) * x


def test_exact_x0_and_eps_models_are_guided_identically(small_spec) -> None:
    """The two parametrisations differ only through the learned model: exact ones give the
    same guided sample, so any difference in notebook 01 comes from learning."""
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    targets = np.array([[1.0, 2.0]] * 4, np.float32)
    results = {}
    for prediction in ("x0", "epsilon"):
        spec = GMDModelSpec(prediction=prediction, diffusion_steps=50,
                                data=DataConfig(frames=FRAMES))
        diffusion = spec.diffusion()
        trained = TrainedGMD(_ExactGaussianDenoiser(diffusion, prediction), diffusion,
                                 space, spec)
        results[prediction] = goal_reaching_experiment(trained, targets, seed=0,
                                                           clip_x0=None)
    x0, eps = results["x0"], results["epsilon"]
    assert torch.allclose(x0.guided, eps.guided, atol=1e-3)
    assert x0.error_guided.mean() < 0.25 * x0.error_unguided.mean()
    assert x0.survival == pytest.approx(eps.survival, abs=1e-3)


def test_settings_build_the_specs_notebook_01_always_trained() -> None:
    from repro.gmd.models import training_fields

    quick = Settings.for_scale("quick")
    data = quick.data(None)
    assert data == DataConfig(stand_in_clips=120, frames=24)
    assert quick.spec("motion", "x0", data, seed=1) == GMDModelSpec(
        task="motion", prediction="x0", data=data, diffusion_steps=20,
        text_conditioned=True).replace(steps=20, batch_size=32, seed=1, validate_every=5,
                                       patience=2)
    full = Settings.for_scale("paper")
    assert full.spec("trajectory", "epsilon", full.data(None)) == GMDModelSpec(
        **training_fields("trajectory", scale="paper"))
    assert Settings.for_scale("paper", train_steps=50).train_steps == 50
    assert full.data("/some/folder") == DataConfig(data_dir="/some/folder", frames=48)
    assert quick.evaluator_config("id").training.steps == 30
    assert full.evaluator_config("id").training.steps == 500
    # GMD-A4's motion models: the same windows in HumanML3D's relative root (MDM's), the
    # trajectory models in GMD's absolute root
    for settings in (quick, full):
        assert settings.motion_data() == dataclasses.replace(settings.data(),
                                                             representation="relative")
        assert settings.data().representation == "absolute"
        assert settings.motion_data("/d") == DataConfig(data_dir="/d", frames=settings.frames,
                                                        representation="relative")


def test_best_gain_survival_on_a_hand_made_path() -> None:
    """Unguided final error 3 m; the guided x̂0 comes within 1 m (best gain 2 m) at its closest
    approach and the guided sample ends at 2.5 m (final gain 0.5 m): survival 0.25."""
    unguided = [3.0, 3.0]
    x0_path = [[4.0, 4.0], [1.5, 0.5], [2.0, 2.0], [2.5, 2.5]]   # steps T−1 … 0, two goals
    assert best_gain_survival(unguided, x0_path, [2.0, 3.0]) == pytest.approx(0.25)
    assert best_gain_survival(unguided, x0_path, [1.0, 1.0]) == pytest.approx(1.0)
    assert best_gain_survival(unguided, x0_path, [3.0, 3.0]) == pytest.approx(0.0)
    assert best_gain_survival(unguided, x0_path, [4.0, 4.0]) == pytest.approx(-0.5)
    # the minimum is over the batch-mean curve: one goal's lucky step does not count alone
    assert best_gain_survival([3.0, 3.0], [[0.0, 4.0], [2.0, 2.0]], [2.5, 2.5]) == pytest.approx(
        0.5)
    assert np.isnan(best_gain_survival([1.0], [[2.0], [1.5]], [1.0]))  # never a gain


def test_goal_reaching_result_reads_the_survival_from_its_own_path(small_spec,
                                                                   cache: Path) -> None:
    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0]], dtype=np.float32)
    result = goal_reaching_experiment(trained, targets, seed=1, strength=10.0)
    assert result.clip_x0 == 6.0  # GMD's clamp of an ε model's x̂0, registered
    expected = best_gain_survival(result.error_unguided, result.x0_error_guided,
                                  result.error_guided)
    assert result.survival == pytest.approx(expected, nan_ok=True)
    assert result.best_gain == pytest.approx(result.error_unguided.mean()
                                             - result.x0_error_guided.mean(axis=1).min())
    assert result.best_step in set(result.timesteps.tolist())


def test_guidance_trajectory_spec_is_gmds_diffusion_and_stops_at_20() -> None:
    from repro.gmd.guidance import default_stop_step, guidance_parameters
    from repro.gmd.x0_vs_eps.common import guidance_trajectory_spec

    full = Settings.for_scale("paper")
    spec = full.guidance_trajectory_spec("epsilon", full.data(None), seed=2)
    assert spec == full.spec("trajectory", "epsilon", full.data(None), seed=2).replace(
        diffusion_steps=1000, schedule="cosine")
    assert spec == guidance_trajectory_spec("paper", seed=2)
    assert spec.diffusion_steps == GUIDANCE_DIFFUSION_STEPS
    assert default_stop_step(1000) == GUIDANCE_STOP_T == 20
    assert default_stop_step(50) == 1 and default_stop_step(100) == 2
    quick = guidance_trajectory_spec("quick", "x0")
    assert quick.diffusion_steps == 50 and quick.prediction == "x0"
    eps = TrainedGMD(torch.nn.Linear(1, 1), spec.diffusion(), None, spec)  # type: ignore[arg-type]
    assert guidance_parameters(eps) == {"num_timesteps": 1000, "guidance_stop_t": 20,
                                        "x0_clamp": 6.0}
    x0 = TrainedGMD(torch.nn.Linear(1, 1), spec.diffusion(), None,  # type: ignore[arg-type]
                    spec.replace(prediction="x0"))
    assert guidance_parameters(x0, stop=0)["x0_clamp"] is None


def test_guided_sampling_at_t_1000_stops_at_t_20() -> None:
    """At T = 1000 the guidance shift is non-zero down to t = 20 and zero below it."""
    from repro.core.diffusion import Guidance

    spec = GMDModelSpec(prediction="x0", diffusion_steps=1000, data=DataConfig(frames=FRAMES))
    diffusion = spec.diffusion()
    space = FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                         np.ones(4, np.float32))
    trained = TrainedGMD(_ExactGaussianDenoiser(diffusion, "x0"), diffusion, space, spec)
    goal = Guidance(lambda x0: (space.root_xz(x0)[:, -1] - 1.0).abs().mean(-1), strength=1.0)
    _, path = sample(trained, 2, seed=0, guidance=goal, return_trajectory=True,
                     trajectory_timesteps=range(30))
    shift = path.guidance_shift.abs().flatten(1).amax(1).numpy()
    steps = np.asarray(path.timesteps)
    assert np.all(shift[steps >= 20] > 0) and np.all(shift[steps < 20] == 0)


def test_clamp_sensitivity_repeats_the_guided_run_under_each_bound(small_spec,
                                                                   cache: Path) -> None:
    from repro.gmd.x0_vs_eps.a3 import CLAMPS, clamp_sensitivity

    trained = load_or_train_gmd(small_spec())
    targets = np.array([[0.5, 1.0], [0.0, 2.0]], dtype=np.float32)
    registered = goal_reaching_experiment(trained, targets, seed=4, strength=10.0)
    errors = clamp_sensitivity({("epsilon", 4): trained}, {("epsilon", 4): registered}, [4])
    assert list(errors) == list(CLAMPS)
    for label, bound in CLAMPS.items():
        again = goal_reaching_experiment(trained, targets, seed=4, strength=10.0, clip_x0=bound)
        assert errors[label][0] == pytest.approx(float(again.error_guided.mean()), rel=1e-5)


# ------------------------------------------------------------------------------------------------
# GMD-A3's controls: the exact x0/ε pair samples identically (the null does not fire), the
# late-reverting model undoes guided gain (the positive is seen).
# ------------------------------------------------------------------------------------------------

torch.set_num_threads(1)


SEEDS = list(range(4))


TARGETS = np.array([[1.0, 2.0], [-0.5, 1.5], [0.3, -1.0]], np.float32)


@pytest.fixture(scope="module")
def windows() -> MotionWindows:
    return load_windows(DataConfig(data_dir=str(data_stubs_dir()), frames=32, stride=8))


@pytest.fixture(scope="module")
def models(windows: MotionWindows) -> dict:
    """What the A3 controls read of the guidance trajectory models (schedule, space, spec)."""
    spec = GMDModelSpec(prediction="x0", diffusion_steps=50, data=DataConfig(frames=32))
    base = TrainedGMD(torch.nn.Linear(1, 1), spec.diffusion(), windows.space("trajectory"),
                      spec)
    return {(p, s): base for s in SEEDS for p in ("x0", "epsilon")}


def test_exact_pair_samples_identically(models) -> None:
    pair = a3.exact_pair(models[("x0", 0)])
    assert pair["x0"].spec.prediction == "x0" and pair["epsilon"].spec.prediction == "epsilon"
    runs = {p: goal_reaching_experiment(m, TARGETS, seed=3, clip_x0=6.0)
            for p, m in pair.items()}
    np.testing.assert_allclose(runs["x0"].guided, runs["epsilon"].guided, atol=1e-4)
    np.testing.assert_allclose(runs["x0"].x0_error_guided, runs["epsilon"].x0_error_guided,
                               atol=1e-4)
    assert runs["x0"].error_guided.mean() < 0.5 * runs["x0"].error_unguided.mean()


def test_late_reverting_model_leaves_the_unguided_run_and_undoes_the_guided_gain(models
                                                                                 ) -> None:
    exact = a3.exact_pair(models[("x0", 0)])["x0"]
    honest = goal_reaching_experiment(exact, TARGETS, seed=3, clip_x0=6.0)
    reverting = a3.late_reverting_model(exact, len(TARGETS), seed=3, below=5, share=0.5)
    planted = goal_reaching_experiment(reverting, TARGETS, seed=3, clip_x0=6.0)
    assert torch.equal(planted.unguided, honest.unguided)
    # guided steps down to the stop are the same; the last (t < 5) lose guided gain
    above = planted.timesteps >= 5
    np.testing.assert_allclose(planted.x0_error_guided[above], honest.x0_error_guided[above],
                               atol=1e-5)
    assert planted.survival < honest.survival - 0.2
    assert planted.error_guided.mean() > honest.error_guided.mean()


def test_a3_null_does_not_fire_and_positive_is_seen(windows, models) -> None:
    claim = get_claim("GMD-A3")
    result = a3.a3_controls(models, windows, SEEDS, goals=6, min_distance=0.0)
    null, positive = result.null, result.positive
    np.testing.assert_allclose(null["goal_error_x0"], null["goal_error_eps"], atol=1e-4)
    assert positive["goal_error_eps"] == null["goal_error_eps"]
    assert claim.decide(null).verdict not in (REPRODUCED, PARTIAL)
    assert claim.decide(positive).verdict == REPRODUCED
    # as the ledger decides a control: exactly, rounding ties zero
    assert claim.decide(null, control=True).verdict not in (REPRODUCED, PARTIAL)
    assert claim.decide(positive, control=True).verdict == REPRODUCED
    assert result.planted["survival_drop_in_delta"] >= 1
    assert result.planted["goal_error_gap_in_delta"] >= 1
    assert result.planted["revert_below_t"] == 1  # GMD's 20/1000 at T = 50


# ------------------------------------------------------------------------------------------------
# Notebook 01's results (``gmd.x0_vs_eps.a1`` … ``a4``): what GMD-A1…A4 record, built from the
# measurements, and the per-seed views of the A3 study.
# ------------------------------------------------------------------------------------------------

#: what every sidecar of notebook 01 records under ``extra["parameters"]``
KEYS = {"num_timesteps", "guidance_stop_t", "x0_clamp"}


def test_a1_and_a2_record_the_registered_measurements_and_the_parameters(
        tmp_path: Path) -> None:
    cosine = schedule_diffusion("cosine", 1000)
    mu_difference = a1.posterior_mean_forms(cosine, samples=4, seed=0)
    printed = a1.printed_c_relative_error(cosine)
    a1_record = a1_result(cosine, mu_difference, printed, figure=tmp_path / "a1.png", seed=0)
    assert set(get_claim("GMD-A1").measurements) <= set(a1_record.measured)
    assert set(a1_record.extra["parameters"]) == KEYS
    assert a1_record.extra["c_equals_one_over_sqrt_alpha_max_error"] == a1.c_identity_error(
        cosine) < 1e-9
    schedules = {name: a2.coefficient_shares(schedule_diffusion(name))
                 for name in ("cosine", "linear")}
    peaks = {name: {k: a2.peak_fraction(v[k]) for k in ("x0_share", "eps_share")}
             for name, v in schedules.items()}
    a2_record = a2_result(schedules, peaks, figure=tmp_path / "a2.png", seed=0)
    assert a2_record.extra["parameters"] == {"num_timesteps": 1000, "guidance_stop_t": None,
                                             "x0_clamp": None}
    assert a2_record.headline.startswith("cosine: x0 share a/(a+b) peaks at t = 1/1000")
    assert set(a2_record.extra["cosine_x0_share_at"]) == {"1", "10", "500", "1000"}
    ctx = make_context(tmp_path, scale="standard")
    # the printed Eq. 2 drops a square root
    assert record(ctx, a1_record).verdict == PAPER_DISCREPANCY
    assert record(ctx, a2_record).verdict == REPRODUCED


def test_every_result_of_notebook_01_records_the_guidance_parameters() -> None:
    calls = [node for module in (a1, a2, a3, a4)
             for node in ast.walk(ast.parse(inspect.getsource(module)))
             if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "ClaimResult"]
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


def test_every_scale_trains_the_eps_motion_arm_with_the_x0_arms_spec() -> None:
    """A4's ε motion arm is a treatment arm, never cut on its expected outcome: every scale
    trains both motion arms, the ε arm at standard with exactly the x0 arm's spec and steps
    (width 64, 4500 steps); the headline of a run without an ε arm still reads."""
    standard = Settings.for_scale("standard")
    data = standard.motion_data()
    x0, eps = (standard.spec("motion", p, data, seed=1) for p in ("x0", "epsilon"))
    assert eps == x0.replace(prediction="epsilon")
    assert x0.base_channels == 64 and x0.training.steps == 4500
    assert set(a4.A4_PARTS) == {p.name for p in get_claim("GMD-A4").parts}
    for scale in ("quick", "standard", "paper"):
        settings = Settings.for_scale(scale)
        assert settings.motion_predictions == ("x0", "epsilon") and settings.a4_not_run == {}
    x0_only = {"motion_jitter_x0": [80.0, 90.0], "motion_fid_x0": [1.5, 2.5],
               "trajectory_jitter_x0": [30.0, 40.0], "trajectory_jitter_eps": [60.0, 80.0]}
    lines = a4.sample_quality_lines(x0_only, [0, 1]).splitlines()
    assert lines[1] == ("seed 1: motion jerk x0 90; FID x0 2.5; trajectory jerk x0 40 / ε 80 "
                        "(jerk m/s³)")
    headline = a4._a4_headline(x0_only, {"trajectory_jitter": 2.0},
                               {"motion_fid": 1.0, "motion_jitter": 70.0}, "standard")
    assert headline.startswith("ε motion arm not run at the standard scale; x0 motion samples: "
                               "joint jerk 85 m/s³ (data 70)")
