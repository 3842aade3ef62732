"""The tiny-GMD library: windows, feature space, cached models, guidance, measurements."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from repro.core import training
from repro.gmd import library as gmd
from repro.motion.features import features_to_joints, relative_to_absolute_root
from repro.motion.humanml3d import MotionDataset
from repro.standin.dataset import write_dataset

torch.set_num_threads(1)
FRAMES = 16


@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_dataset(tmp_path_factory.mktemp("stand_in"), n_clips=10, seed=3)


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _config(root: Path, representation: str = "absolute") -> gmd.DataConfig:
    return gmd.DataConfig(data_dir=str(root), frames=FRAMES, stride=8,
                          representation=representation)


def _spec(root: Path, **changes) -> gmd.GMDModelSpec:
    base = dict(task="trajectory", prediction="epsilon", data=_config(root), base_channels=8,
                channel_mults=(1, 2), diffusion_steps=20, train_steps=3, batch_size=8)
    return gmd.GMDModelSpec(**{**base, **changes})


def test_windows_shape_normalisation_and_round_trip(dataset_dir: Path) -> None:
    windows = gmd.load_windows(_config(dataset_dir))
    assert windows.x.dtype == torch.float32 and windows.x.shape[1:] == (263, FRAMES)
    # normalised with the training windows' own mean: every channel averages to 0
    assert windows.x.mean(dim=(0, 2)).abs().max() < 1e-4
    # un-normalising gives the absolute-root features of the raw window, each from the origin
    clip = MotionDataset(dataset_dir, "train", normalise=False)[0]
    raw = clip["motion"][:FRAMES].double()
    expected = relative_to_absolute_root(raw).float()
    assert windows.ids[0] == f"{clip['id']}:0"
    np.testing.assert_allclose(windows.features()[0].numpy(), expected.numpy(), atol=2e-5)
    again = windows.space("motion").normalise(windows.features()[:3])
    np.testing.assert_allclose(again.numpy(), windows.x[:3].numpy(), atol=1e-4)


def test_trajectory_view_is_angle_x_z_y_of_the_root(dataset_dir: Path) -> None:
    windows = gmd.load_windows(_config(dataset_dir))
    view = windows.trajectory()
    assert view.shape[1] == 4 and torch.equal(view, windows.x[:, 0:4])
    clip = MotionDataset(dataset_dir, "train", normalise=False)[0]
    root = features_to_joints(clip["motion"][:FRAMES].double())[:, 0]   # (T, 3) world root
    positions = windows.space("trajectory").root_positions(view[:1])[0]
    np.testing.assert_allclose(positions.numpy(), root.numpy(), atol=2e-5)
    # the relative representation recovers the same root path through recover_root
    relative = gmd.load_windows(_config(dataset_dir, "relative"))
    rel_positions = relative.space("trajectory").root_positions(relative.trajectory()[:1])[0]
    np.testing.assert_allclose(rel_positions.numpy(), root.numpy(), atol=2e-5)


def test_other_splits_use_the_training_statistics(dataset_dir: Path) -> None:
    train = gmd.load_windows(_config(dataset_dir))
    test = gmd.load_windows(_config(dataset_dir), "test", statistics=(train.mean, train.std))
    assert np.array_equal(test.mean, train.mean) and test.split == "test"


def test_max_windows_cuts_only_the_training_split(dataset_dir: Path) -> None:
    full = gmd.load_windows(_config(dataset_dir))
    config = gmd.DataConfig(data_dir=str(dataset_dir), frames=FRAMES, stride=8, max_windows=5)
    cut = gmd.load_windows(config)
    assert len(cut) == 5 < len(full) and set(cut.ids) <= set(full.ids)
    assert "max_windows" not in _config(dataset_dir).as_dict()
    assert cut.fingerprint != full.fingerprint


def test_model_is_cached_and_the_key_covers_the_data(dataset_dir: Path, cache: Path,
                                                     tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    spec = _spec(dataset_dir)
    windows = gmd.load_windows(spec.data)
    first = gmd.load_or_train_gmd(spec, windows)
    assert len(first.metrics["losses"]) == 3

    def no_training(*args, **kwargs):
        raise AssertionError("the second call must load the cached model")

    monkeypatch.setattr(gmd, "train_diffusion", no_training)
    second = gmd.load_or_train_gmd(spec, windows)
    assert second.cache_key == first.cache_key
    for a, b in zip(first.model.parameters(), second.model.parameters(), strict=True):
        assert torch.equal(a, b)
    monkeypatch.setattr(gmd, "train_diffusion", training.train_diffusion)
    other_dir = write_dataset(tmp_path / "other", n_clips=10, seed=4)
    other = _spec(other_dir)
    assert gmd.load_or_train_gmd(other).cache_key != first.cache_key
    with pytest.raises(ValueError, match="spec trains on"):
        gmd.load_or_train_gmd(other, windows)


def test_stand_in_data_is_generated_when_no_folder_is_given(cache: Path) -> None:
    config = gmd.DataConfig(stand_in_clips=8, stand_in_seed=1, frames=FRAMES, stride=8)
    windows = gmd.load_windows(config)
    assert str(windows.root).startswith(str(cache)) and len(windows) > 0


@pytest.mark.parametrize("prediction", ["epsilon", "x0"])
def test_goal_gradient_flows_to_x_t(dataset_dir: Path, cache: Path, prediction: str) -> None:
    trained = gmd.load_or_train_gmd(_spec(dataset_dir, prediction=prediction, train_steps=5))
    x_t = torch.randn(2, 4, FRAMES, requires_grad=True)
    t = torch.full((2,), 10, dtype=torch.long)
    out = trained.diffusion.p_mean_variance(trained.model, x_t, t)
    goal = gmd.goal_reaching_loss(trained.space, [[1.0, 2.0], [-1.0, 0.5]])(out.pred_x0)
    assert goal.shape == (2,)
    (grad,) = torch.autograd.grad(goal.sum(), x_t)
    assert torch.isfinite(grad).all() and grad[:, 1:3, -1].abs().min() > 0


def test_goal_reaching_experiment_and_measurements(dataset_dir: Path, cache: Path) -> None:
    trained = gmd.load_or_train_gmd(_spec(dataset_dir))
    targets = np.array([[0.5, 1.0], [0.0, 2.0], [-0.5, 1.5]], dtype=np.float32)
    result = gmd.goal_reaching_experiment(trained, targets, seed=0, strength=10.0)
    assert result.guided.shape == (3, 4, FRAMES) and result.stop_guidance_at == 0
    assert result.x0_error_guided.shape == (20, 3) and result.timesteps[0] == 19
    np.testing.assert_allclose(result.error_guided,
                               gmd.goal_error(trained, result.guided, targets), rtol=1e-6)
    assert np.isfinite(result.survival) and result.best_step_error >= 0
    jitter = gmd.jitter_of(trained, result.unguided)
    assert jitter.acceleration > 0 and jitter.jerk > 0
    # the same seed without guidance is the same sample
    again = gmd.sample(trained, 3, seed=0)
    assert torch.allclose(again, result.unguided)


def test_guided_change_survival_definition() -> None:
    space = gmd.FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    base = torch.randn(3, 4, FRAMES)
    change = torch.zeros_like(base)
    change[:, 1:3] = torch.randn(3, 2, FRAMES)
    survival = gmd.guided_change_survival
    assert survival(space, base + change, base, base + change, base) == pytest.approx(1.0)
    assert survival(space, base + change, base, base, base) == pytest.approx(0.0)
    assert survival(space, base + change, base, base + 0.25 * change, base) == pytest.approx(0.25)
    assert np.isnan(survival(space, base, base, base + change, base))
    assert gmd.goal_error_kept([3.0, 3.0], [1.0, 1.0], [3.0, 2.0]) == pytest.approx(0.25)
    assert np.isnan(gmd.goal_error_kept([1.0], [2.0], [1.5]))


def test_appendix_a_coefficients() -> None:
    diffusion = gmd.schedule_diffusion("cosine", 1000)
    assert gmd.posterior_mean_forms(diffusion, samples=8).max() < 1e-12
    assert gmd.printed_c_relative_error(diffusion).max() > 1e-6
    shares = gmd.coefficient_shares(diffusion)
    np.testing.assert_allclose(shares["c"], 1 / np.sqrt(diffusion.alphas), rtol=1e-12)
    assert gmd.peak_fraction(shares["x0_share"]) == pytest.approx(0.001)


def test_bag_of_words_and_loss_weights(dataset_dir: Path) -> None:
    windows = gmd.load_windows(_config(dataset_dir))
    bow = gmd.bag_of_words(windows.vocabulary, ["a person walks", ["walks", "a person runs"]])
    assert bow.shape == (2, len(windows.vocabulary))
    np.testing.assert_allclose(bow.sum(1).numpy(), [1.0, 1.0], rtol=1e-6)
    weights = gmd.trajectory_loss_weights(5)
    assert weights[:4] == [25.0] * 4 and weights[4] == 1.0 and len(weights) == 263


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


def test_exact_x0_and_eps_models_are_guided_identically() -> None:
    """The two parametrisations differ only through the learned model: exact ones give the
    same guided sample, so any difference in notebook 01 comes from learning."""
    space = gmd.FeatureSpace("trajectory", "absolute", np.zeros(4, np.float32),
                             np.ones(4, np.float32))
    targets = np.array([[1.0, 2.0]] * 4, np.float32)
    results = {}
    for prediction in ("x0", "epsilon"):
        spec = gmd.GMDModelSpec(prediction=prediction, diffusion_steps=50,
                                data=gmd.DataConfig(frames=FRAMES))
        diffusion = spec.diffusion()
        trained = gmd.TrainedGMD(_ExactGaussianDenoiser(diffusion, prediction), diffusion,
                                 space, spec)
        results[prediction] = gmd.goal_reaching_experiment(trained, targets, seed=0,
                                                           clip_x0=None)
    x0, eps = results["x0"], results["epsilon"]
    assert torch.allclose(x0.guided, eps.guided, atol=1e-3)
    assert x0.error_guided.mean() < 0.25 * x0.error_unguided.mean()
    assert x0.survival == pytest.approx(eps.survival, abs=1e-3)


def test_load_or_train_many_trains_missing_models_in_worker_processes(dataset_dir: Path,
                                                                      cache: Path) -> None:
    specs = [_spec(dataset_dir, prediction=p, train_steps=2) for p in ("x0", "epsilon")]
    windows = gmd.load_windows(specs[0].data)
    assert not any(gmd.is_cached(spec, windows) for spec in specs)
    trained = gmd.load_or_train_many(specs, windows, workers=2)
    assert all(gmd.is_cached(spec, windows) for spec in specs)
    assert [t.spec.prediction for t in trained] == ["x0", "epsilon"]
    in_process = gmd.load_or_train_gmd(specs[1], windows)
    assert in_process.cache_key == trained[1].cache_key
