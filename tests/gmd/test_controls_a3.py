"""GMD-A3's controls: the exact x0/ε pair samples identically (the null does not fire), the
late-reverting model undoes guided gain (the positive is seen)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.claims.registry import get_claim
from repro.claims.verdicts import PARTIAL, REPRODUCED
from repro.gmd import x0_vs_eps
from repro.gmd.models import GMDModelSpec, TrainedGMD
from repro.gmd.windows import DataConfig, MotionWindows, load_windows
from repro.gmd.x0_vs_eps import goal_reaching_experiment
from repro.infra.paths import data_stubs_dir

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
    pair = x0_vs_eps.exact_pair(models[("x0", 0)])
    assert pair["x0"].spec.prediction == "x0" and pair["epsilon"].spec.prediction == "epsilon"
    runs = {p: goal_reaching_experiment(m, TARGETS, seed=3, clip_x0=6.0)
            for p, m in pair.items()}
    np.testing.assert_allclose(runs["x0"].guided, runs["epsilon"].guided, atol=1e-4)
    np.testing.assert_allclose(runs["x0"].x0_error_guided, runs["epsilon"].x0_error_guided,
                               atol=1e-4)
    assert runs["x0"].error_guided.mean() < 0.5 * runs["x0"].error_unguided.mean()


def test_late_reverting_model_leaves_the_unguided_run_and_undoes_the_guided_gain(models
                                                                                 ) -> None:
    exact = x0_vs_eps.exact_pair(models[("x0", 0)])["x0"]
    honest = goal_reaching_experiment(exact, TARGETS, seed=3, clip_x0=6.0)
    reverting = x0_vs_eps.late_reverting_model(exact, len(TARGETS), seed=3, below=5,
                                                 share=0.5)
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
    result = x0_vs_eps.a3_controls(models, windows, SEEDS, goals=6, min_distance=0.0)
    null, positive = result.null, result.positive
    np.testing.assert_allclose(null["goal_error_x0"], null["goal_error_eps"], atol=1e-4)
    assert positive["goal_error_eps"] == null["goal_error_eps"]
    assert claim.decide(null).verdict not in (REPRODUCED, PARTIAL)
    assert claim.decide(positive).verdict == REPRODUCED
    assert result.planted["survival_drop_in_delta"] >= 1
    assert result.planted["goal_error_gap_in_delta"] >= 1
    assert result.planted["revert_below_t"] == 1  # GMD's 20/1000 at T = 50
