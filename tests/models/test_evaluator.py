"""The tiny contrastive evaluator on a toy set where the caption names a distinct motion class."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.models import evaluator as ev
from repro.models.evaluator import (
    Evaluator,
    EvaluatorConfig,
    evaluate_generated,
    feature_statistics,
    info_nce,
    load_or_train_evaluator,
    train_evaluator,
)

torch.set_num_threads(1)

ACTIONS = ("walks", "jumps", "waves", "kicks")
MANNERS = ("slowly", "quickly", "to the left", "to the right")
FAST = EvaluatorConfig(hidden=64, dim=32).replace(steps=80, seed=0)
FRAMES = 48
PADDING_VALUE = 100.0


def toy_set(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """16 classes (action × manner): the action sets a sinusoid's frequency on its own block
    of features, the manner shifts another block; padding holds garbage; contacts are random."""
    rng = np.random.default_rng(seed)
    action, manner = rng.integers(4, size=n), rng.integers(4, size=n)
    lengths = rng.integers(32, FRAMES + 1, size=n)
    motions = rng.normal(0.0, 0.3, (n, FRAMES, 263)).astype(np.float32)
    t = np.arange(FRAMES) / 20.0
    for i in range(n):
        a, m = action[i], manner[i]
        motions[i, :, 10 * a:10 * a + 10] += np.sin(2 * np.pi * (1 + a) * t)[:, None]
        motions[i, :, 100 + 5 * m:105 + 5 * m] += 1.0
        motions[i, lengths[i]:] = PADDING_VALUE
    motions[..., 259:] = rng.integers(0, 2, (n, FRAMES, 4))
    captions = [f"A person {ACTIONS[a]} {MANNERS[m]}." for a, m in zip(action, manner, strict=True)]
    return motions, lengths, captions


@pytest.fixture(scope="module")
def trained() -> Evaluator:
    return train_evaluator(*toy_set(320, seed=0), FAST)


def test_trained_evaluator_retrieves_far_above_chance(trained):
    motions, lengths, captions = toy_set(128, seed=1)  # held out
    result = evaluate_generated(trained, motions, lengths, captions, motions, lengths, seed=0)
    # chance is 1/32; identical captions in a batch cap top-1 near 0.4 on this toy set
    assert result["r_precision_top1"] > 0.25
    assert result["r_precision_top3"] > 0.6
    assert result["tmr_m2t"] > 0.8
    assert np.mean(trained.losses[-10:]) < 0.5 * trained.losses[0]
    shuffled = list(np.random.default_rng(0).permutation(captions))
    worse = evaluate_generated(trained, motions, lengths, shuffled, motions, lengths, seed=0)
    assert worse["r_precision_top1"] < 0.15
    assert worse["mm_dist"] > result["mm_dist"]


def test_evaluate_generated_against_itself_and_against_other_motions(trained):
    motions, lengths, captions = toy_set(64, seed=2)
    same = evaluate_generated(trained, motions, lengths, captions, motions, lengths, seed=0,
                              include_ground_truth=True)
    assert set(same) >= {"fid", "r_precision_top1", "r_precision_top2", "r_precision_top3",
                         "mm_dist", "diversity", "tmr_m2t", "tmr_m2m", "gt_r_precision_top1"}
    assert abs(same["fid"]) < 1e-6 and same["tmr_m2m"] == pytest.approx(1.0)
    assert same["diversity_pairs"] == 64
    noise = np.random.default_rng(3).normal(0.0, 1.0, motions.shape).astype(np.float32)
    other = evaluate_generated(trained, noise, lengths, captions, motions, lengths, seed=0)
    assert other["fid"] > 0.1 and other["tmr_m2m"] < same["tmr_m2m"]
    with pytest.raises(ValueError, match="pair"):
        evaluate_generated(trained, motions, lengths, captions, motions[:32], lengths[:32],
                           seed=0)
    with pytest.raises(ValueError, match="caption"):
        evaluate_generated(trained, motions, lengths, captions[:5], motions, lengths, seed=0)


def test_embeddings_ignore_foot_contacts_and_padding(trained):
    motions, lengths, _ = toy_set(16, seed=4)
    base = trained.embed_motions(motions, lengths)
    changed = motions.copy()
    changed[..., 259:] = 1.0 - changed[..., 259:]
    for i, n in enumerate(lengths):
        changed[i, n:] = -PADDING_VALUE
    np.testing.assert_allclose(trained.embed_motions(changed, lengths), base, atol=1e-5)
    longer = np.concatenate([motions, np.full((16, 60, 263), 7.0, np.float32)], axis=1)
    np.testing.assert_allclose(trained.embed_motions(longer, lengths), base, atol=1e-5)
    shortest = int(np.argmin(lengths))
    alone = trained.embed_motions(motions[shortest:shortest + 1, :lengths[shortest]],
                                  lengths[shortest:shortest + 1])
    np.testing.assert_allclose(alone[0], base[shortest], atol=1e-5)
    body = motions.copy()
    body[:, :, 50] += 1.0
    assert np.abs(trained.embed_motions(body, lengths) - base).max() > 1e-3
    np.testing.assert_allclose(np.linalg.norm(base, axis=1), 1.0, rtol=1e-5)


def test_normalisation_statistics_come_from_the_training_split(trained):
    motions, lengths, _ = toy_set(320, seed=0)
    valid = np.arange(FRAMES)[None] < lengths[:, None]
    frames = motions[valid][:, :259].astype(np.float64)
    np.testing.assert_allclose(trained.mean, frames.mean(0), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(trained.std, np.maximum(frames.std(0), FAST.std_floor), rtol=1e-5)
    assert trained.mean.shape == (259,)  # foot contacts excluded


def test_save_load_roundtrip(trained, tmp_path):
    motions, lengths, captions = toy_set(8, seed=5)
    trained.save(tmp_path / "ev")
    loaded = Evaluator.load(tmp_path / "ev")
    assert loaded.config == trained.config and loaded.vocab == trained.vocab
    np.testing.assert_array_equal(loaded.embed_motions(motions, lengths),
                                  trained.embed_motions(motions, lengths))
    np.testing.assert_array_equal(loaded.embed_texts(captions), trained.embed_texts(captions))
    assert loaded.losses == trained.losses


def test_training_is_deterministic_and_seed_dependent():
    data = toy_set(40, seed=6)
    config = EvaluatorConfig(hidden=16, dim=8).replace(steps=3, batch_size=16)
    a, b = train_evaluator(*data, config), train_evaluator(*data, config)
    c = train_evaluator(*data, config.replace(seed=1))
    np.testing.assert_array_equal(a.embed_motions(data[0], data[1]),
                                  b.embed_motions(data[0], data[1]))
    assert not np.allclose(a.embed_motions(data[0], data[1]), c.embed_motions(data[0], data[1]))


def test_load_or_train_caches_by_config_and_data(tmp_path, monkeypatch):
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    data = toy_set(40, seed=7)
    config = EvaluatorConfig(hidden=16, dim=8).replace(steps=2, batch_size=16)
    calls = []
    real_fit = ev._fit

    def counting_fit(*args, **kwargs):
        calls.append(1)
        return real_fit(*args, **kwargs)

    monkeypatch.setattr(ev, "_fit", counting_fit)
    first = load_or_train_evaluator(*data, config)
    again = load_or_train_evaluator(*data, config)
    assert len(calls) == 1
    np.testing.assert_array_equal(again.embed_texts(data[2]), first.embed_texts(data[2]))
    np.testing.assert_array_equal(again.embed_motions(data[0], data[1]),
                                  first.embed_motions(data[0], data[1]))
    assert again.losses == first.losses and len(again.losses) == 2
    load_or_train_evaluator(*data, config.replace(seed=3))
    load_or_train_evaluator(data[0] + 1.0, data[1], data[2], config)
    assert len(calls) == 3
    assert len(list((tmp_path / "evaluator").iterdir())) == 3
    repadded = data[0].copy()
    repadded[np.arange(FRAMES)[None] >= data[1][:, None]] = 0.0
    load_or_train_evaluator(repadded, data[1], data[2], config)  # same valid frames: a hit
    assert len(calls) == 3


def test_a_cached_evaluator_is_the_one_train_evaluator_makes(tmp_path, monkeypatch):
    """load_or_train_evaluator computes the statistics only on a miss; the trained entry and
    the entry read back hold the same statistics and weights as train_evaluator's."""
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path))
    data = toy_set(40, seed=5)
    config = EvaluatorConfig(hidden=16, dim=8).replace(steps=3, batch_size=16)
    direct = train_evaluator(*data, config)
    mean, std = feature_statistics(data[0], data[1], config.std_floor)
    for model in (load_or_train_evaluator(*data, config), load_or_train_evaluator(*data, config)):
        np.testing.assert_allclose(model.mean, mean.astype(np.float32), rtol=0, atol=0)
        np.testing.assert_allclose(model.std, std.astype(np.float32), rtol=0, atol=0)
        assert model.losses == direct.losses
        np.testing.assert_array_equal(model.embed_motions(data[0], data[1]),
                                      direct.embed_motions(data[0], data[1]))


def test_info_nce_and_duplicate_captions():
    aligned = torch.eye(4) * 5.0
    assert info_nce(aligned, aligned, 0.01) < 1e-6
    twins = torch.tensor([[1.0, 0.0], [1.0, 0.0]])
    assert info_nce(twins, twins, 0.1) == pytest.approx(np.log(2.0), rel=1e-5)
    same = torch.tensor([[True, True], [True, True]])
    assert info_nce(twins, twins, 0.1, same) < 1e-6


def test_bad_input_is_rejected():
    motions, lengths, captions = toy_set(8, seed=8)
    with pytest.raises(ValueError, match="263"):
        train_evaluator(motions[..., :259], lengths, captions, FAST)
    with pytest.raises(ValueError, match="captions"):
        train_evaluator(motions, lengths, captions[:3], FAST)
    with pytest.raises(ValueError, match="lengths"):
        train_evaluator(motions, lengths + FRAMES, captions, FAST)
    nan = motions.copy()
    nan[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        train_evaluator(nan, lengths, captions, FAST)


def test_the_config_holds_its_training_and_keys_as_before():
    """``EvaluatorConfig`` holds a ``TrainConfig``; its key and config.json form are the flat
    fields of the config before it did (so every cached evaluator keeps its key)."""
    config = EvaluatorConfig(dim=8, data_id="d").replace(steps=7, seed=2)
    assert config.training.steps == 7 and config.training.grad_clip is None
    assert config.as_dict() == {"dim": 8, "hidden": 128, "word_dim": 64, "max_text_len": 24,
                                "min_count": 1, "steps": 7, "batch_size": 64, "lr": 1e-3,
                                "weight_decay": 0.01, "temperature": 0.1, "std_floor": 0.01,
                                "seed": 2, "data_id": "d"}
    assert EvaluatorConfig.from_dict(config.as_dict()) == config
    with pytest.raises(ValueError, match="does not use"):
        EvaluatorConfig().replace(ema_decay=0.5)
