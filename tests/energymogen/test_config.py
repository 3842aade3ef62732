"""The design of the stand-in composition test (repro.energymogen.config): the held-out pairs,
the sets of three and the negation cases, and the one pipeline configuration per mode."""

from __future__ import annotations

from dataclasses import fields, replace

from repro.energymogen.data import trained_pairs
from repro.energymogen.settings import (
    ARM_CONCEPTS,
    EXTRA_TEST_SETS,
    HELD_OUT_PAIRS,
    LOWER_CONCEPTS,
    NEGATION_CASES,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
    PipelineConfig,
    config_summary,
    pipeline_config,
)
from repro.standin.concepts import can_be_simultaneous


def test_held_out_pairs_are_composable_and_never_trained() -> None:
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    assert len(held) == len(HELD_OUT_PAIRS) == 10
    assert all(can_be_simultaneous(*p) for p in HELD_OUT_PAIRS)
    assert not held & {frozenset(p) for p in trained_pairs()}
    assert len(trained_pairs()) == len(LOWER_CONCEPTS) * len(ARM_CONCEPTS) - 10
    for pair, negated in NEGATION_CASES:
        assert frozenset(pair) not in held and negated in pair


def test_sets_of_three_and_their_control_name_the_same_motions() -> None:
    assert [s[0] for s in THREE_CONCEPT_SETS] == list(LOWER_CONCEPTS)
    assert all(s[1:] == ("wave_left", "wave_right") for s in THREE_CONCEPT_SETS)
    assert THREES_AS_PAIRS == tuple((s[0], "wave_both") for s in THREE_CONCEPT_SETS)
    assert EXTRA_TEST_SETS["threes"][0] == THREE_CONCEPT_SETS
    assert EXTRA_TEST_SETS["threes_as_pairs"][0] == THREES_AS_PAIRS


def test_full_mode_is_the_default_config_and_quick_only_shrinks() -> None:
    full, quick = pipeline_config("paper"), pipeline_config("quick")
    assert full == PipelineConfig()
    changed = {f.name for f in fields(PipelineConfig) if getattr(full, f.name) != getattr(
        quick, f.name)}
    trainings = {"vae_training", "text_training", "denoiser_training", "evaluator"}
    assert changed == {"n_train_clips", "test_clips_per_pair", "ddim_steps", "items_per_pair",
                       "items_per_extra_set"} | trainings
    assert all(getattr(quick, name) < getattr(full, name) for name in changed - trainings)
    for name in trainings:   # only the step counts shrink
        quick_training, full_training = (getattr(quick, name), getattr(full, name))
        if name == "evaluator":
            quick_training, full_training = quick_training.training, full_training.training
        assert quick_training.steps < full_training.steps
        assert replace(quick_training, steps=full_training.steps) == full_training
    assert config_summary(full)["latent_count"] == 5
    assert full.data_dict()["held_out"] == [list(p) for p in HELD_OUT_PAIRS]
