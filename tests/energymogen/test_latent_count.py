"""EMG-7 (repro.energymogen.latent_count): models with N latent vectors trained exactly as the
pipeline's, MPJPE, the Table 8 layout, and a tiny end-to-end study."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from conftest import TINY_PIPELINE as TINY

from repro.claims.registry import get_claim
from repro.energymogen import settings as emg_settings
from repro.energymogen.harness import TextToMotionTest, load_or_build_text_to_motion_test
from repro.energymogen.latent_count import emg7 as lc
from repro.energymogen.pipeline import EnergyMoGenPipeline


def test_paper_table8_is_the_registry_value() -> None:
    recon = [lc.PAPER_TABLE8["reconstruction"][str(n)]["fid"] for n in emg_settings.LATENT_COUNTS]
    gen = [lc.PAPER_TABLE8["generation"][str(n)]["fid"] for n in emg_settings.LATENT_COUNTS]
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


@pytest.fixture(scope="module")
def tiny(tiny_pipeline: EnergyMoGenPipeline) -> tuple[EnergyMoGenPipeline, TextToMotionTest]:
    return tiny_pipeline, load_or_build_text_to_motion_test(TINY, 40)


def test_variant_is_trained_as_the_pipeline(tiny) -> None:
    pipe, _ = tiny
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
    pipe, test = tiny
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
    records = lc.latent_count_records(pipe, results, (1, 5, 7), [0], test)
    assert [r["arm"] for r in records] == ["N=1", "N=1", "N=5", "N=5", "N=7", "N=7"]
    assert [r["role"] for r in records[2:4]] == ["reference", "reference"]


def test_example_reconstructions_take_each_variant(tiny) -> None:
    pipe, test = tiny
    index, reconstructions = lc.example_reconstructions(pipe, test, (1, 5), 0)
    assert len(test.concepts[index]) == 2
    assert all(len(c) == 1 for c in test.concepts[:index])
    assert [n for n, _, _ in reconstructions] == [1, 5]
    clip = test.features[index:index + 1]
    recon = pipe.decode(pipe.encode_motion(clip))
    n5, joints5, error5 = reconstructions[1]
    assert error5 == pytest.approx(lc.mpjpe(recon, clip))
    assert np.allclose(joints5, pipe.joints(recon)[0])
