"""EMG-8 (repro.energymogen.composed_augmentation): the composed set, training rows, fine-tuning
from the pretrained denoiser without touching it, and a tiny end-to-end study."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from conftest import TINY_AUGMENTATION_PIPELINE as TINY

from repro.claims.registry import get_claim
from repro.energymogen import settings as emg_settings
from repro.energymogen.composed_augmentation import compml, emg8
from repro.energymogen.harness import TextToMotionTest, load_or_build_text_to_motion_test
from repro.energymogen.pipeline import EnergyMoGenPipeline, SeedPipelines, load_pipeline
from repro.energymogen.settings import FRAMES, HELD_OUT_PAIRS, PipelineConfig


def test_pairs_sizes_and_schedule() -> None:
    pairs = compml.composable_pairs()
    assert len(pairs) == 35 and {frozenset(p) for p in HELD_OUT_PAIRS} <= set(
        map(frozenset, pairs))
    assert emg_settings.composed_set_size(PipelineConfig()) == 342
    config = emg_settings.finetune_config(PipelineConfig(), seed=3)
    assert (config.steps, config.lr, config.seed) == (833, 2.5e-4, 3)
    assert config.batch_size == 128 and config.cond_dropout == 0.1


def test_concatenate_rows_pads_tokens() -> None:
    a = compml.Rows(torch.zeros(2, 5, 4), torch.ones(2, 3, 6), torch.ones(2, 3, dtype=torch.bool))
    b = compml.Rows(torch.ones(1, 5, 4), torch.ones(1, 5, 6), torch.ones(1, 5, dtype=torch.bool))
    both = compml.concatenate_rows(a, b)
    assert both.tokens.shape == (3, 5, 6) and both.mask.shape == (3, 5) and len(both) == 3
    assert not both.mask[:2, 3:].any() and both.mask[2].all()
    assert both.tokens[:2, 3:].abs().sum() == 0


@pytest.fixture(scope="module")
def tiny(emg_cache: object) -> tuple[EnergyMoGenPipeline, TextToMotionTest]:
    return load_pipeline(TINY, log=None), load_or_build_text_to_motion_test(TINY, 32)


def test_composed_set_and_rows(tiny) -> None:
    pipe, _ = tiny
    composed = compml.compose_set(pipe, 6, seed=0)
    assert len(composed) == 6 and composed.features.shape == (6, FRAMES, 263)
    assert composed.presence().shape == (6, 2)
    assert compml.compose_set(pipe, 6, seed=0).texts == composed.texts
    words = {w.strip(".,") for t in composed.texts for w in t.lower().split()}
    assert all(w in pipe.vocab for w in words)
    rows = compml.caption_rows(pipe, composed.features, [(t,) for t in composed.texts])
    assert rows.latents.shape == (6, *pipe.latent_shape) and rows.mask.shape[0] == 6


def test_finetuning_starts_from_the_pretrained_denoiser(tiny) -> None:
    pipe, _ = tiny
    before = [p.detach().clone() for p in pipe.denoiser.parameters()]
    rows = compml.caption_rows(pipe, pipe.data.train_features[:8], pipe.data.train_captions[:8])
    config = emg_settings.finetune_config(pipe.config, seed=0)
    tuned, record = compml.load_or_finetune(pipe, rows, config)
    again, cached = compml.load_or_finetune(pipe, rows, config)  # from the cache
    assert record.steps == cached.steps == config.steps and record.train_seconds > 0
    for p, q in zip(pipe.denoiser.parameters(), before, strict=True):
        assert torch.equal(p, q)
    assert any(not torch.equal(p, q) for p, q in zip(tuned.parameters(), before, strict=True))
    for p, q in zip(tuned.parameters(), again.parameters(), strict=True):
        assert torch.equal(p, q)


def test_finetuning_takes_a_third_of_the_steps_the_pretrained_denoiser_used(tiny) -> None:
    pipe, _ = tiny
    assert compml.pipeline_finetune_config(pipe, 0).steps == round(
        pipe.training["denoiser"].steps / 3)
    assert emg_settings.finetune_config(pipe.config, 0, pretraining_steps=30).steps == 10


def test_every_seed_fine_tunes_its_own_pretrained_model(tiny) -> None:
    """Pretraining seeds vary: seed s composes and fine-tunes from the models of
    training seed data_seed + s, not from one pretrained model shared by every seed."""
    pipe, test = tiny
    seeds = SeedPipelines(pipe, log=None)
    results = emg8.augmentation_study(seeds, test, [0, 1], size=4)
    assert results["pretrained_train_seeds"] == [TINY.data_seed, TINY.data_seed + 1]
    assert [r.steps for r in results["training"]["control"]] == [
        compml.pipeline_finetune_config(seeds(s), s).steps for s in (0, 1)]
    _check_aa_controls(seeds, test, results)


def _check_aa_controls(seeds: SeedPipelines, test: TextToMotionTest, results: dict) -> None:
    """EMG-8's A/A: seed s's control denoiser against the other seed's (the study's own,
    measured with seed s's draws); the two trainings differ (no zero spread), and read as
    exact paired draws (each seed's difference repeated) the null would fire."""
    controls = emg8.augmentation_controls(seeds, test, results, [0, 1])
    assert controls is not None and controls.exact is False
    null, base = controls.null, results["t2m"]["control"]
    assert null["r_precision_top3_baseline"] == base["r_precision_top3"]
    assert null["fid_baseline"] == base["fid"]
    claim = get_claim("EMG-8")
    fid = claim.parts[1].compare(null)[0].differences
    assert all(abs(d) > 1e-9 for d in fid)                      # two trainings differ
    repeated = {name: [values[0]] * 3 for name, values in null.items()}
    assert claim.parts[1].name == "fid_improves"
    outcome = {p.name: p.outcome for p in claim.decide(repeated, control=True).parts}
    assert outcome["fid_improves"] in ("supported", "contradicted")
    planted = np.subtract(controls.positive["r_precision_top3_augmented"],
                          null["r_precision_top3_augmented"])
    assert planted == pytest.approx([0.02, 0.02])


def test_study_feeds_the_rule(tiny) -> None:
    pipe, test = tiny
    results = emg8.augmentation_study(pipe, test, [0, 1], size=8)
    for part in ("t2m", "held_out"):
        assert set(results[part]) == set(emg8.ROWS)
        assert len(results[part]["augmented"]["fid"]) == 2
    assert len(results["example"]) == 8 and len(results["composed"]["both_present"]) == 2
    t2m = results["t2m"]
    measured = {"r_precision_top3_augmented": t2m["augmented"]["r_precision_top3"],
                "r_precision_top3_baseline": t2m["control"]["r_precision_top3"],
                "fid_augmented": t2m["augmented"]["fid"], "fid_baseline": t2m["control"]["fid"]}
    decision = get_claim("EMG-8").decide(measured)  # every part fed, none "not recorded"
    assert [(p.name, "not recorded" in p.reason) for p in decision.parts] == [
        (p.name, False) for p in get_claim("EMG-8").parts]
