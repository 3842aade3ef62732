"""GMD-B2's location imputation: abs replaces the two target entries, rel imputes the facing
path through both targets on every frame, guidance and imputation run like for like."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.gmd import root_representation as L
from repro.gmd.guidance import sample
from repro.gmd.models import TrainedGMD
from repro.gmd.root_representation import Settings
from repro.gmd.windows import DataConfig, FeatureSpace
from repro.motion.features import FEATURE_DIM, recover_root


def _task(n: int = 3, frames: int = 16) -> L.LocationTask:
    rng = np.random.default_rng(1)
    return L.LocationTask(rng.normal(0.0, 1.0, (n, 2, 2)).astype(np.float32), frames // 2 - 1,
                          frames - 1)


def _space(representation: str) -> FeatureSpace:
    return FeatureSpace("trajectory", representation, np.array([0.1, 0.2, -0.3, 0.9]),
                        np.array([0.5, 2.0, 1.5, 0.1]))


def _untrained(representation: str, frames: int = 16, steps: int = 10) -> TrainedGMD:
    """An untrained UNet (its zero-initialised output layer predicts ε = 0)."""
    spec = Settings.for_scale("quick").trajectory_spec(representation, 0).replace(
        diffusion_steps=steps, data=DataConfig(frames=frames, representation=representation))
    return TrainedGMD(spec.build_model().eval(), spec.diffusion(), _space(representation), spec)


def _features(root: np.ndarray) -> torch.Tensor:
    features = np.zeros(root.shape[:-1] + (FEATURE_DIM,))
    features[..., :3] = root
    return torch.from_numpy(features)


def test_abs_imputation_replaces_only_the_target_entries() -> None:
    task, frames = _task(), 16
    space = _space("absolute")
    imputation = L.abs_location_imputation(space, task, frames)
    assert int(imputation.mask.sum()) == 4
    assert imputation.mask[0, 1:3][:, list(task.frames)].all()
    x = torch.randn(task.n, 4, frames)
    x = torch.where(imputation.mask, imputation.target, x)
    assert L.location_errors(space, x, task).max() < 1e-5
    loss = L.location_loss(space, task)(x)
    assert loss.shape == (task.n,) and float(loss.max()) < 1e-5


@pytest.mark.parametrize("representation", ["absolute", "relative"])
def test_imputation_through_the_last_step_reaches_the_targets_exactly(representation) -> None:
    """With the stop at t = 0 the last step writes the target itself on the mask: abs hits
    its two entries, rel its recovered path, to float32 rounding; a stop after t = 0 leaves
    free steps (the untrained model's ε = 0 then moves the masked entries)."""
    trained, task = _untrained(representation), _task()
    make = (L.abs_location_imputation if representation == "absolute"
            else L.rel_location_imputation)
    imputation = make(trained.space, task, 16)
    x = sample(trained, task.n, seed=3, imputation=imputation, stop_guidance_at=0, clip_x0=6.0)
    assert torch.equal(x[imputation.mask.expand_as(x)],
                       imputation.target.expand_as(x)[imputation.mask.expand_as(x)])
    assert L.location_errors(trained.space, x, task).max() < 1e-4
    late = sample(trained, task.n, seed=3, imputation=imputation, stop_guidance_at=5,
                  clip_x0=6.0)
    assert not torch.equal(late[imputation.mask.expand_as(x)],
                           imputation.target.expand_as(x)[imputation.mask.expand_as(x)])


def test_facing_path_walks_forward_through_both_targets() -> None:
    task, frames = _task(4, 20), 20
    root = L.facing_path_root(task, frames)
    assert root.shape == (4, frames, 3)
    _, position = recover_root(_features(root))
    position = position.numpy()[..., [0, 2]]
    np.testing.assert_allclose(position[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(position[:, task.waypoint_frame], task.targets[:, 0], atol=1e-6)
    np.testing.assert_allclose(position[:, task.goal_frame], task.targets[:, 1], atol=1e-6)
    # facing the direction of travel: no sideways (local x) velocity, positive forward speed
    np.testing.assert_allclose(root[:, :-1, 1], 0.0, atol=1e-9)
    assert (root[:, :-1, 2] > 0).all()
    # constant speed per leg, one turn at the first step and one at the waypoint
    i = task.waypoint_frame
    np.testing.assert_allclose(root[:, :i, 2] - root[:, :1, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(root[:, i:-1, 2] - root[:, i:i + 1, 2], 0.0, atol=1e-9)
    turning = np.abs(root[:, :-1, 0]) > 1e-12
    assert set(np.nonzero(turning)[1]) <= {0, i}
    assert (np.abs(root[:, :-1, 0]) <= np.pi / 2 + 1e-12).all()


def test_rel_imputation_fixes_the_root_of_every_frame() -> None:
    task, frames = _task(), 16
    space = _space("relative")
    imputation = L.rel_location_imputation(space, task, frames)
    assert imputation.mask[0, :3].all() and not imputation.mask[0, 3].any()
    x = imputation.target.clone()
    assert L.location_errors(space, x, task).max() < 1e-5
    with pytest.raises(ValueError, match="relative-root"):
        L.rel_location_imputation(_space("absolute"), task, frames)


def test_location_loss_is_l1_over_both_frames() -> None:
    task, frames = _task(1), 16
    space = _space("absolute")
    x = space.normalise(torch.zeros(1, frames, 4))
    expected = np.abs(task.targets).sum()
    assert float(L.location_loss(space, task)(x)) == pytest.approx(expected, rel=1e-5)


def test_impute_locations_runs_every_method_like_for_like() -> None:
    task = _task(2, 16)
    models = {rep: _untrained(rep) for rep in ("absolute", "relative")}
    runs = L.impute_locations(models, task, seed=0, stop_t=0, clip_x0=6.0)
    assert set(runs) == set(L.METHODS)
    assert runs["abs_imputation"].mean_error < 1e-4
    assert runs["rel_imputation"].mean_error < 1e-4
    assert runs["abs_unguided"].path_change == 0.0
    assert all(np.isfinite(run.location_error).all() for run in runs.values())
    measured = L.registered_measurements({0: runs, 1: runs})
    assert set(measured) == {"abs_imputation_error", "rel_imputation_error",
                             "abs_guidance_error", "rel_guidance_error",
                             "abs_location_error", "rel_location_error"}
    assert measured["rel_location_error"] == measured["rel_guidance_error"]
    assert measured["abs_location_error"] == [runs["abs_imputation"].mean_error] * 2
