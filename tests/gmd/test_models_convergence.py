"""GMD models that can represent their data and are trained to convergence."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch

from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.emphasis_projection import Settings as EmphasisSettings
from repro.gmd.guidance_schedule import Settings as ScheduleSettings
from repro.gmd.models import (
    MOTION_TRAINING,
    GMDModelSpec,
    load_or_train_gmd,
    longer_run,
    model_cache_config,
    training_fields,
    validation_split,
)
from repro.gmd.root_representation import Settings as RootSettings
from repro.gmd.windows import load_windows
from repro.infra.cache import config_hash
from repro.models.unet import narrowest_full_resolution_width


def _full_mode_specs() -> dict[str, GMDModelSpec]:
    nb01 = x0eps.Settings.for_scale("paper")
    nb02 = RootSettings.for_scale("paper")
    data = nb01.data()
    return {
        "01 motion x0": nb01.spec("motion", "x0", nb01.motion_data()),
        "01 motion ε": nb01.spec("motion", "epsilon", nb01.motion_data()),
        "01 trajectory x0": nb01.spec("trajectory", "x0", data),
        "01 trajectory ε": nb01.spec("trajectory", "epsilon", data),
        "02 motion": nb02.motion_spec("absolute", 0),
        "02 trajectory": nb02.trajectory_spec("relative", 0),
        "03 base": EmphasisSettings.for_scale("paper").base_spec(),
        "06 trajectory": ScheduleSettings.for_scale("paper").spec(),
    }


def test_every_full_mode_model_is_at_least_as_wide_as_its_data() -> None:
    for name, spec in _full_mode_specs().items():
        model = spec.build_model(cond_dim=8 if spec.text_conditioned else None)
        width = narrowest_full_resolution_width(model)
        assert width >= spec.channels, f"{name}: full-resolution width {width} < {spec.channels}"
        if spec.task == "motion":
            assert width >= 263


def test_full_mode_models_train_to_convergence_and_x0_and_eps_share_everything_else() -> None:
    specs = _full_mode_specs()
    for name, spec in specs.items():
        assert spec.training.validate_every is not None, name
        # the spec's training (cond_dropout only acts on a text-conditioned model)
        config = spec.train_config()
        assert dataclasses.replace(config, cond_dropout=spec.training.cond_dropout) == (
            spec.training), name
        assert config.cond_dropout == (spec.training.cond_dropout if spec.text_conditioned
                                       else 0.0), name
    assert specs["01 motion x0"].replace(prediction="epsilon") == specs["01 motion ε"]
    assert specs["01 trajectory x0"].replace(prediction="epsilon") == specs["01 trajectory ε"]
    assert specs["01 motion x0"].training.steps == MOTION_TRAINING.step_cap


def test_convergence_fields_enter_the_key_only_when_set(small_spec) -> None:
    data = SimpleNamespace(fingerprint="0123456789abcdef")
    plain = small_spec()
    assert "validate_every" not in plain.as_dict() and "patience" not in plain.as_dict()
    assert plain.train_config().validate_every is None
    validated = small_spec(validate_every=2)
    assert validated.as_dict()["validate_every"] == 2
    keys = {config_hash(model_cache_config(spec, data))
            for spec in (plain, validated, small_spec(validate_every=2, patience=3),
                         small_spec(validate_every=2, min_delta=0.05),
                         small_spec(validate_every=2, validation_fraction=0.2))}
    assert len(keys) == 5
    with pytest.raises(ValueError, match="only act with validate_every"):
        small_spec(patience=3)
    with pytest.raises(ValueError, match="validation_fraction"):
        small_spec(validate_every=2, validation_fraction=1.0)


def test_validation_split_holds_out_whole_training_clips(small_config) -> None:
    windows = load_windows(small_config())
    fit, held = validation_split(windows, 0.2)
    assert len(fit) + len(held) == len(windows) and len(held) > 0
    clip = [window_id.rsplit(":", 1)[0] for window_id in windows.ids]
    assert not {clip[i] for i in held.tolist()} & {clip[i] for i in fit.tolist()}
    again = validation_split(windows, 0.2)
    assert torch.equal(again[1], held)
    assert len(validation_split(windows, 0.01)[1]) > 0          # at least one clip


def test_quick_mode_exercises_the_convergence_path() -> None:
    fields = training_fields("motion", scale="quick", step_cap=20)
    assert fields["training"].steps == 20 and fields["training"].validate_every < 20
    assert "base_channels" not in fields               # quick keeps its tiny model
    quick = x0eps.Settings.for_scale("quick")
    spec = quick.spec("motion", "x0", quick.data())
    assert spec.training.validate_every is not None and spec.base_channels == 16
    with pytest.raises(ValueError, match="step_cap"):
        training_fields("motion", scale="quick")


def test_a_model_trained_with_validation_records_its_convergence(small_spec,
                                                                  cache: Path) -> None:
    spec = small_spec(steps=8, validate_every=2, patience=1, min_delta=0.5,
                      validation_fraction=0.2)
    windows = load_windows(spec.data)
    trained = load_or_train_gmd(spec, windows)
    convergence = trained.metrics["convergence"]
    assert convergence["step_cap"] == 8
    assert convergence["steps_used"] == len(trained.metrics["losses"]) <= 8
    assert [step for step, _ in convergence["validation"]][:2] == [0, 2]
    values = {"x0_error_vs_gaussian": 0.5, "path_length": 1.0}
    record = model_gates.gmd_model_record(trained, family="gmd_trajectory", values=values,
                                          reference={"path_length": 1.0}, role="treatment")
    assert record["steps"] == convergence["steps_used"]
    assert record["converged"] is convergence["converged"]
    assert record["validation_curve"] == [loss for _, loss in convergence["validation"]]
    assert record["convergence"]["step_cap"] == 8
    assert load_or_train_gmd(spec, windows).cache_key == trained.cache_key


def test_on_validation_sees_each_evaluation_and_leaves_the_model_as_it_was(
        small_spec, cache: Path) -> None:
    spec = small_spec(steps=6, validate_every=2, patience=10, validation_fraction=0.2)
    windows = load_windows(spec.data)
    seen: list[tuple[int, float]] = []

    def watch(step: int, loss: float, ema_model: torch.nn.Module) -> None:
        assert not ema_model.training
        seen.append((step, loss))

    watched = load_or_train_gmd(spec, windows, on_validation=watch)
    assert seen == [tuple(point) for point in watched.metrics["convergence"]["validation"]]
    assert [step for step, _ in seen] == [0, 2, 4, 6]
    plain = load_or_train_gmd(spec, windows, retrain=True)
    assert plain.cache_key == watched.cache_key
    for name, value in plain.model.state_dict().items():
        assert torch.equal(value, watched.model.state_dict()[name]), name


def test_longer_run_doubles_the_cap_and_cannot_stop_on_the_plateau(small_spec) -> None:
    spec = small_spec(steps=8, validate_every=2)
    longer = longer_run(spec).training
    assert longer.steps == 16 and longer.patience * longer.validate_every > 16
    assert longer_run(spec).replace(steps=8, patience=spec.training.patience) == spec
    with pytest.raises(ValueError, match="validate_every"):
        longer_run(small_spec())
