"""Tiny-GMD models: the cache key covers the data, text conditioning, loss weights, workers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from repro.core import training
from repro.gmd import models
from repro.gmd.models import (
    GMDModelSpec,
    bag_of_words,
    is_cached,
    load_or_train_gmd,
    load_or_train_many,
    model_cache_config,
    trajectory_loss_weights,
)
from repro.gmd.windows import DataConfig, load_windows
from repro.standin.dataset import write_dataset

FRAMES = 16  # = conftest.FRAMES: the windows of the small_config fixture


def test_model_is_cached_and_the_key_covers_the_data(small_config, small_spec, cache: Path,
                                                     tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    spec = small_spec()
    windows = load_windows(spec.data)
    first = load_or_train_gmd(spec, windows)
    assert len(first.metrics["losses"]) == 3

    def no_training(*args, **kwargs):
        raise AssertionError("the second call must load the cached model")

    monkeypatch.setattr(models, "train_diffusion", no_training)
    second = load_or_train_gmd(spec, windows)
    assert second.cache_key == first.cache_key
    for a, b in zip(first.model.parameters(), second.model.parameters(), strict=True):
        assert torch.equal(a, b)
    monkeypatch.setattr(models, "train_diffusion", training.train_diffusion)
    other_dir = write_dataset(tmp_path / "other", n_clips=10, seed=4)
    other = small_spec(root=other_dir)
    assert load_or_train_gmd(other).cache_key != first.cache_key
    with pytest.raises(ValueError, match="spec trains on"):
        load_or_train_gmd(other, windows)


def test_bag_of_words_and_loss_weights(small_config, small_spec) -> None:
    windows = load_windows(small_config())
    bow = bag_of_words(windows.vocabulary, ["a person walks", ["walks", "a person runs"]])
    assert bow.shape == (2, len(windows.vocabulary))
    np.testing.assert_allclose(bow.sum(1).numpy(), [1.0, 1.0], rtol=1e-6)
    weights = trajectory_loss_weights(5)
    assert weights[:4] == [25.0] * 4 and weights[4] == 1.0 and len(weights) == 263


def test_load_or_train_many_trains_missing_models_in_worker_processes(small_config, small_spec,
                                                                      cache: Path) -> None:
    specs = [small_spec(prediction=p, steps=2) for p in ("x0", "epsilon")]
    windows = load_windows(specs[0].data)
    assert not any(is_cached(spec, windows) for spec in specs)
    trained = load_or_train_many(specs, windows, workers=2)
    assert all(is_cached(spec, windows) for spec in specs)
    assert [t.spec.prediction for t in trained] == ["x0", "epsilon"]
    in_process = load_or_train_gmd(specs[1], windows)
    assert in_process.cache_key == trained[1].cache_key


#: cache keys of models (spec + a fixed data fingerprint): a refactor that changes one would
#: orphan every cached model, so a key changes only with a deliberate change of a model's spec,
#: its data or the cache version (git log of this table says which: convergence training,
#: T = 1000 guidance models, seeded initialisation, the motion family's cap and autocast, the
#: fourth standard design of docs/COMPUTE.md §16).
PINNED_MODEL_KEYS = {
    "default": "f404c269f4481ef1",
    "nb01_quick_motion_x0": "1940edf5cf9ef4fa",
    "nb02_traj_rel_full": "db87a4df2b1d91e2",
    "nb02_motion_abs_quick": "5da2d7cb1ad217e5",
    "nb03_k5_full": "c343960f21e3f130",
    "nb03_c10_quick": "3a96e9aa72c5c446",
    "max_windows": "d8d336cf2fe0cf09",
}
#: window fingerprints (part of every model key) of the 10-clip seed-3 stand-in folder;
#: changed on purpose with generator v3 (partial captions, free body parts).
PINNED_WINDOW_FINGERPRINTS = {"absolute": "f4045791fc65bb18", "relative": "2d4a020827358396"}


def _pinned_specs() -> dict[str, GMDModelSpec]:
    from repro.gmd.emphasis_projection import Settings as EmphasisSettings
    from repro.gmd.emphasis_projection.experiment import Variant
    from repro.gmd.root_representation import Settings as RootSettings

    quick_motion = GMDModelSpec(task="motion", prediction="x0",
                                data=DataConfig(stand_in_clips=120, frames=24),
                                diffusion_steps=20).replace(steps=20, batch_size=32, seed=1)
    return {
        "default": GMDModelSpec(),
        "nb01_quick_motion_x0": quick_motion,
        "nb02_traj_rel_full": RootSettings.for_scale("paper").trajectory_spec("relative", 2),
        "nb02_motion_abs_quick": RootSettings.for_scale("quick").motion_spec("absolute", 0),
        "nb03_k5_full": Variant("loss_scaling", 5).spec(
            EmphasisSettings.for_scale("paper").base_spec(), 1),
        "nb03_c10_quick": Variant("emphasis", 10).spec(
            EmphasisSettings.for_scale("quick").base_spec(), 0),
        "max_windows": GMDModelSpec(data=DataConfig(max_windows=7, representation="relative")),
    }


def test_model_cache_keys_are_pinned() -> None:
    from types import SimpleNamespace

    from repro.infra.cache import config_hash

    data = SimpleNamespace(fingerprint="0123456789abcdef")
    keys = {name: config_hash(model_cache_config(spec, data))
            for name, spec in _pinned_specs().items()}
    assert keys == PINNED_MODEL_KEYS


def test_window_fingerprints_are_pinned(small_config) -> None:
    found = {rep: load_windows(small_config(rep)).fingerprint for rep in ("absolute", "relative")}
    assert found == PINNED_WINDOW_FINGERPRINTS


def test_initialisation_comes_from_the_seed_alone() -> None:
    spec = GMDModelSpec(base_channels=8, channel_mults=(1, 2)).replace(seed=4)
    first = spec.build_model().state_dict()
    torch.manual_seed(123)
    torch.randn(17)
    state = torch.random.get_rng_state()
    again = spec.build_model().state_dict()
    assert torch.equal(torch.random.get_rng_state(), state), "the global RNG was touched"
    assert all(torch.equal(first[name], again[name]) for name in first)
    other = spec.replace(seed=5).build_model().state_dict()
    assert not all(torch.equal(first[name], other[name]) for name in first)


def test_autocast_is_opt_in_and_in_the_key_only_when_set() -> None:
    from types import SimpleNamespace

    from repro.infra.cache import config_hash

    data = SimpleNamespace(fingerprint="0123456789abcdef")
    fp32 = GMDModelSpec()
    bf16 = fp32.replace(autocast="bfloat16")
    assert "autocast" not in fp32.as_dict()
    assert bf16.as_dict()["autocast"] == "bfloat16"
    assert (config_hash(model_cache_config(fp32, data))
            != config_hash(model_cache_config(bf16, data)))
    assert fp32.train_config().autocast is None
    assert bf16.train_config().autocast == "bfloat16"
    with pytest.raises(ValueError, match="autocast must be one of"):
        GMDModelSpec().replace(autocast="float16")


def test_input_skip_is_opt_in_in_the_key_only_when_set_and_reaches_the_unet() -> None:
    from types import SimpleNamespace

    from repro.infra.cache import config_hash

    data = SimpleNamespace(fingerprint="0123456789abcdef")
    plain = GMDModelSpec(task="motion")
    skip = plain.replace(input_skip=True)
    assert "input_skip" not in plain.as_dict() and skip.as_dict()["input_skip"] is True
    assert (config_hash(model_cache_config(plain, data))
            != config_hash(model_cache_config(skip, data)))
    assert plain.build_model().input_gain is None
    assert skip.build_model().input_gain is not None


def test_full_mode_motion_trains_under_bf16_and_the_rest_in_fp32() -> None:
    assert models.training_fields("motion", scale="paper")["training"].autocast == "bfloat16"
    assert models.training_fields("trajectory", scale="paper")["training"].autocast is None
    assert models.training_fields("motion", scale="quick", step_cap=10)["training"].autocast is None


def test_caption_draw_one_trains_on_one_caption_per_window_and_is_in_the_key() -> None:
    """``caption_draw="one"`` (HumanML3D's loader: a caption drawn per item at every batch)
    stacks each window's captions as alternatives (N, K, V), an item with fewer cycling its
    own; "mean" leaves the key as it was."""
    from types import SimpleNamespace

    from repro.infra.cache import config_hash
    from repro.standin.text import Vocabulary

    vocabulary = Vocabulary.build(["a person walks", "a person runs", "someone jumps"])
    alternatives = models.caption_alternatives(
        vocabulary, [["a person walks", "a person runs"], ["someone jumps"]])
    assert alternatives.shape == (2, 2, len(vocabulary))
    assert torch.equal(alternatives[1, 0], alternatives[1, 1])
    assert torch.equal(alternatives[0, 1], bag_of_words(vocabulary, ["a person runs"])[0])
    data = SimpleNamespace(fingerprint="0123456789abcdef")
    mean = GMDModelSpec(task="motion", text_conditioned=True, caption_draw="mean")
    one = mean.replace(caption_draw="one")
    assert GMDModelSpec().caption_draw == "one"      # the default, as HumanML3D's loaders
    assert "caption_draw" not in mean.as_dict() and one.as_dict()["caption_draw"] == "one"
    assert (config_hash(model_cache_config(mean, data))
            != config_hash(model_cache_config(one, data)))
    assert "caption_draw" not in GMDModelSpec(caption_draw="one").as_dict()   # reads no text
    with pytest.raises(ValueError, match="caption_draw"):
        GMDModelSpec(caption_draw="all")
