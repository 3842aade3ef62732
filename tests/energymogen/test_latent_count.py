"""EMG-7 helpers (repro.latent_count): the held-out test set, models with N latent vectors
trained exactly as the pipeline's, MPJPE, the Table 8 layout, and a tiny end-to-end study."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.claims.registry import get_claim
from repro.energymogen import latent_count as lc
from repro.energymogen import pipeline as em

torch.set_num_threads(1)

TINY = em.PipelineConfig(n_train_clips=24, test_clips_per_pair=2, vae_steps=2, text_steps=2,
                         denoiser_steps=2, evaluator_steps=2, ddim_steps=2, items_per_pair=4)


def test_paper_table8_is_the_registry_value() -> None:
    recon = [lc.PAPER_TABLE8["reconstruction"][str(n)]["fid"] for n in lc.LATENT_COUNTS]
    gen = [lc.PAPER_TABLE8["generation"][str(n)]["fid"] for n in lc.LATENT_COUNTS]
    assert recon == [0.170, 0.117, 0.080, 0.022] and gen == [0.424, 0.418, 0.188, 0.291]
    paper = get_claim("EMG-7").paper_value
    assert all(f"{v:.3f}" in paper for v in recon + gen)
    assert lc.PAPER_TABLE8["generation"]["5"]["r_precision_top3"] == 0.815


def test_mpjpe_of_a_lifted_body() -> None:
    rng = np.random.default_rng(0)
    features = rng.normal(0, 0.1, (2, 10, 263)).astype(np.float32)
    lifted = features.copy()
    lifted[..., 3] += 0.1                 # root height: every joint moves up by 0.1 m
    lifted[..., 4:67][..., 1::3] += 0.1   # the other joints' y is absolute
    assert lc.mpjpe(features, features) == 0.0
    assert lc.mpjpe(features, lifted) == pytest.approx(0.1, abs=1e-6)


def test_oracle_accuracy_takes_ragged_concept_lists() -> None:
    joints = np.zeros((2, 40, 22, 3), np.float32)
    assert lc.oracle_accuracy(joints, [("jump",), ("walk_forward", "clap")]) == 0.0
    with pytest.raises(ValueError, match="2 motions for 1"):
        lc.oracle_accuracy(joints, [("jump",)])


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory):
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(cache))
        pipe = em.load_pipeline(TINY, log=None)
        test = lc.load_or_build_text_to_motion_test(TINY, 40)
        again = lc.load_or_build_text_to_motion_test(TINY, 40)
        yield pipe, test, again


def test_text_to_motion_test_is_held_out_and_in_distribution(tiny) -> None:
    pipe, test, again = tiny
    assert test.features.shape == (40, em.FRAMES, 263) and len(test.captions) == 40
    assert np.array_equal(test.features, again.features) and test.captions == again.captions
    trained = {frozenset(p) for p in em.trained_pairs()}
    for names in test.concepts:
        assert len(names) == 1 or frozenset(names) in trained
    assert {len(c) for c in test.concepts} == {1, 2}
    for clip in pipe.data.train_features:       # no training clip is a test clip
        assert not np.any(np.all(np.isclose(test.features, clip[None]), axis=(1, 2)))
    assert test.texts(0) == test.texts(0) and test.texts(0) != test.texts(1)


def test_variant_is_trained_as_the_pipeline(tiny) -> None:
    pipe, _, _ = tiny
    assert lc.load_or_train_variant(pipe, TINY.latent_count, TINY.data_seed) is pipe
    same = lc._train_variant(pipe, pipe.config, pipe.config.data_seed, 1, None)
    for a, b in zip(same.vae.parameters(), pipe.vae.parameters(), strict=True):
        assert torch.equal(a, b)
    for a, b in zip(same.denoiser.parameters(), pipe.denoiser.parameters(), strict=True):
        assert torch.equal(a, b)
    assert same.latent_scale == pytest.approx(pipe.latent_scale)
    other = lc.load_or_train_variant(pipe, 3, 1)
    assert other.latent_shape == (3, TINY.latent_dim) and other.text_encoder is pipe.text_encoder
    assert other.vae.latent_count == 3 and other.denoiser.latent_count == 3


def test_study_feeds_the_rule(tiny) -> None:
    pipe, test, _ = tiny
    results = lc.latent_count_study(pipe, test, (1, 5, 7), [0])
    for part in ("reconstruction", "generation"):
        assert set(results[part]) == {"1", "5", "7"}
        assert all(len(v) == 1 for v in results[part]["5"].values())
    assert {"mpjpe", "fid", "r_precision_top3", "oracle_accuracy"} <= set(
        results["reconstruction"]["7"])
    assert results["seconds"]["5"] == [0.0]
    measured = {"reconstruction_error": {n: v["mpjpe"] for n, v in
                                         results["reconstruction"].items()},
                "generation_fid": {n: v["fid"] for n, v in results["generation"].items()}}
    decision = get_claim("EMG-7").decide(measured)  # every part fed, none "not recorded"
    assert [(p.name, "not recorded" in p.reason) for p in decision.parts] == [
        (p.name, False) for p in get_claim("EMG-7").parts]
    table = lc.table8_markdown(results, counts=(1, 5, 7))
    assert "[0.188]" in table and "real motion" in table and table.count("\n") == 8
