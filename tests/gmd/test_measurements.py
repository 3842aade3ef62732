"""Motion-quality measurements of tiny-GMD samples: the root jitter of known paths."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from repro.core.diffusion import GaussianDiffusion, cosine_betas
from repro.gmd import measurements as B
from repro.gmd.measurements import (
    feature_blocks,
    high_frequency_share,
    jitter_of,
    noise_floor,
    reconstruction,
    sample_quality,
    x0_error_by_block,
)
from repro.gmd.windows import FeatureSpace
from repro.motion.features import FEATURE_DIM, FPS


def _space() -> FeatureSpace:
    return FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                        np.ones(4, np.float32))


def _path(x_of_frame: np.ndarray) -> torch.Tensor:
    x = torch.zeros(1, 4, len(x_of_frame), dtype=torch.float64)
    x[0, 1] = torch.as_tensor(x_of_frame)            # root x (m) in the absolute representation
    return x


def test_root_jitter_of_constant_velocity_is_zero() -> None:
    jitter = jitter_of(_space(), _path(0.05 * np.arange(20.0)))
    assert jitter.acceleration == pytest.approx(0.0, abs=1e-9)
    assert jitter.jerk == pytest.approx(0.0, abs=1e-6)


def test_root_acceleration_of_a_parabola() -> None:
    a = 0.001                                          # x = a·f² (m): Δ²x = 2a per frame²
    jitter = jitter_of(_space(), _path(a * np.arange(20.0) ** 2))
    assert jitter.acceleration == pytest.approx(2 * a * FPS**2, rel=1e-6)
    assert jitter.jerk == pytest.approx(0.0, abs=1e-6)


# ------------------------------------------------------------------------------------------------
# Table B.1 on stand-in data (GMD-B3): window concepts, the paper's rows, the ledger layout.
# ------------------------------------------------------------------------------------------------

def test_window_concepts() -> None:
    sequential = {"composition": "sequential", "concepts": ["clap", "walk_forward"],
                  "segments": [{"concept": "clap", "start": 0, "end": 46},
                               {"concept": "walk_forward", "start": 46, "end": 90}]}
    assert B.window_concepts(sequential, 0, 48) == {"clap"}
    assert B.window_concepts(sequential, 22, 48) == {"walk_forward", "clap"}
    assert B.window_concepts(sequential, 24, 48) == {"walk_forward"}
    assert B.window_concepts(sequential, 42, 48) == {"walk_forward"}
    single = {"composition": "simultaneous", "concepts": ["wave_left", "walk_forward"]}
    assert B.window_concepts(single, 30, 48) == {"wave_left", "walk_forward"}


def test_paper_table_matches_the_registry() -> None:
    from repro.claims.registry import get_claim

    value = get_claim("GMD-B3").paper_value
    for row in ("Ours (rel)", "Ours (abs)"):
        for number in B.PAPER_TABLE_B1[row]:
            assert f"{number:g}" in value


def test_registered_measurements_use_the_short_labels() -> None:
    row = {"fid": 1.0, "r_precision_top3": 0.5, "diversity": 2.0, "concept_recall": 0.1}
    rows = {"relative": [row, {**row, "fid": 3.0}], "absolute": [{**row, "fid": 2.0}] * 2}
    measured = B.registered_measurements({"diversity": 9.0}, rows)
    assert measured["fid_rel"] == [1.0, 3.0] and measured["fid_abs"] == [2.0, 2.0]
    assert measured["diversity_real"] == 9.0 and len(measured) == 7
    assert list(B.by_label(rows)) == ["rel", "abs"]
    table = B.table_b1_markdown({"fid": 0.1, "r_precision_top3": 0.9, "diversity": 9.0,
                                 "concept_recall": 0.8}, rows)
    assert "| tiny GMD (rel) | 2.000 ± " in table and "| tiny GMD (abs) | 2.000 ± 0.000" in table


# ------------------------------------------------------------------------------------------------
# The denoiser diagnostics on inputs whose answers are known.
# ------------------------------------------------------------------------------------------------

FRAMES = 32


def _x0_diffusion(steps: int = 100) -> GaussianDiffusion:
    return GaussianDiffusion(cosine_betas(steps), prediction="x0")


def _copy_input(x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    return x_t


def _zeros(x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    return torch.zeros_like(x_t)


def test_blocks_are_named_for_the_absolute_root_and_cover_every_channel() -> None:
    absolute = feature_blocks("absolute")
    assert absolute["root_xz"] == slice(1, 3) and absolute["root_angle"] == slice(0, 1)
    assert "root_linear_velocity" in feature_blocks("relative")
    covered = sorted(c for s in absolute.values() for c in range(FEATURE_DIM)[s])
    assert covered == list(range(FEATURE_DIM))


def test_a_model_that_copies_its_input_errs_by_the_noise_it_was_given() -> None:
    diffusion = _x0_diffusion()
    x0 = torch.zeros(64, FEATURE_DIM, FRAMES)
    errors = x0_error_by_block(_copy_input, diffusion, x0, [0, 10, 50])
    for t, row in errors.items():
        assert row["noise"] == pytest.approx(math.sqrt(1 - diffusion.alphas_cumprod[t]))
        assert row["ric_positions"] == pytest.approx(row["noise"], rel=0.02)
    assert errors[0]["noise"] < errors[10]["noise"] < errors[50]["noise"]


def test_a_model_that_ignores_its_input_errs_by_the_data_at_every_t() -> None:
    x0 = 0.5 * torch.ones(8, FEATURE_DIM, FRAMES)
    errors = x0_error_by_block(_zeros, _x0_diffusion(), x0, [0, 99])
    assert all(row["root_xz"] == pytest.approx(0.5) for row in errors.values())


def test_reconstruction_of_an_epsilon_model_inverts_its_noise_prediction() -> None:
    diffusion = GaussianDiffusion(cosine_betas(100), prediction="epsilon")
    x0 = torch.randn(4, FEATURE_DIM, FRAMES, generator=torch.Generator().manual_seed(1))
    true_noise = torch.randn(x0.shape, generator=torch.Generator().manual_seed(7))

    def oracle(x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        return true_noise

    rebuilt = reconstruction(oracle, diffusion, x0, 30, seed=7)
    assert torch.allclose(rebuilt, x0, atol=1e-4)
    with pytest.raises(ValueError, match="t must be in"):
        reconstruction(oracle, diffusion, x0, 100)


def test_high_frequency_share_separates_alternation_from_smooth_motion() -> None:
    frames = torch.arange(FRAMES + 1, dtype=torch.float64)    # an even number of differences
    x = torch.zeros(2, FEATURE_DIM, FRAMES + 1, dtype=torch.float64)
    x[:, 1] = 0.05 * frames                                    # a ramp: Δx constant
    x[:, 4] = torch.sin(2 * math.pi * frames / FRAMES)         # one slow period
    x[:, 67] = (-1.0) ** frames                                # even/odd alternation
    shares = high_frequency_share(x)
    assert shares["root_xz"] == pytest.approx(0.0, abs=1e-12)
    assert shares["ric_positions"] < 0.01
    assert shares["rot_6d"] == pytest.approx(1.0)
    assert shares["foot_contact"] == 0.0                       # no motion at all
    with pytest.raises(ValueError, match="above"):
        high_frequency_share(x, above=0.6)


def test_noise_floor_grows_with_sigma_and_starts_at_the_data() -> None:
    rng = np.random.default_rng(0)
    space = FeatureSpace("motion", "absolute", np.zeros(FEATURE_DIM, np.float32),
                         np.ones(FEATURE_DIM, np.float32))
    features = np.zeros((4, FRAMES, FEATURE_DIM), np.float32)
    features[:, :, 2] = 0.05 * np.arange(FRAMES)               # walk forward along z
    features[:, :, 3] = 0.9                                    # root height
    features[:, :, 4:67] = np.tile(rng.normal(0, 0.3, 63), (4, FRAMES, 1))
    x = torch.from_numpy(features).transpose(1, 2).contiguous()
    rows = noise_floor(space, x, [0.0, 0.01, 0.05], {"root": slice(0, 4)},
                       sample_quality)
    assert [r["sigma"] for r in rows] == [0.0, 0.01, 0.05]
    jerks = [r["joint_jerk"] for r in rows]
    assert jerks[0] == pytest.approx(0.0, abs=0.01)            # float32 rounding × fps³
    assert jerks[0] < jerks[1] < jerks[2]
    trajectory = FeatureSpace("trajectory", "absolute", np.zeros(4), np.ones(4))
    with pytest.raises(ValueError, match="motion task"):
        noise_floor(trajectory, x[:, :4], [0.0], {"all": slice(0, 4)}, dict)
