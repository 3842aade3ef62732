"""The seeds each GMD claim runs come from one table per scale (registry v4): the notebooks'
settings read it, and their ``n_seeds`` parameters default to it (None: the scale's)."""

from __future__ import annotations

import pytest

from repro.claims.registry import get_claim
from repro.core.training import TrainConfig
from repro.gmd import emphasis_projection, guidance_schedule, models, root_representation, x0_vs_eps
from repro.gmd import root_representation as rr
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.emphasis_projection.experiment import Variant
from repro.gmd.emphasis_projection.projection import ProjectionSettings
from repro.gmd.models import GMDModelSpec, training_fields
from repro.gmd.settings import (
    FULL_SEEDS,
    QUICK_SEEDS,
    STANDARD_NOT_RUN,
    STANDARD_SEEDS,
    not_run,
    scale_note,
    seeds_of,
)
from repro.gmd.x0_vs_eps.common import guidance_trajectory_spec
from repro.models.evaluator import EvaluatorConfig
from repro.run.params import notebook_parameters


def test_settings_read_the_table() -> None:
    assert (x0_vs_eps.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-A4"]
            == FULL_SEEDS["GMD-A3"])
    assert guidance_schedule.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-F1"]
    full = root_representation.Settings.for_scale("paper")
    assert (full.seeds, full.motion_seeds) == (FULL_SEEDS["GMD-B2"], FULL_SEEDS["GMD-B3"])
    assert emphasis_projection.Settings.for_scale("paper").seeds == FULL_SEEDS["GMD-C4"]
    assert seeds_of("GMD-B3", "quick") == QUICK_SEEDS
    assert seeds_of("GMD-C4", "paper") == 6
    with pytest.raises(ValueError, match="GMD-A1"):
        seeds_of("GMD-A1", "paper")
    with pytest.raises(KeyError):   # a helper takes the scale its settings constructor checked
        seeds_of("GMD-A4", "full")


def test_standard_runs_three_seeds_for_every_claim() -> None:
    assert set(STANDARD_SEEDS) == set(FULL_SEEDS)
    assert all(seeds_of(claim, "standard") == 3 for claim in FULL_SEEDS)
    standard = root_representation.Settings.for_scale("standard")
    assert (standard.seeds, standard.motion_seeds) == (3, 3)
    assert x0_vs_eps.Settings.for_scale("standard").seeds == 3
    assert guidance_schedule.Settings.for_scale("standard").seeds == 3
    assert emphasis_projection.Settings.for_scale("standard").seeds == 3


def test_the_standard_scale_cuts_only_registered_parts_and_says_so() -> None:
    """The cuts name parts of their claims; quick runs them (a test of the code), the paper
    scale decides them; the standard notebooks' scale note names them."""
    for claim_id, parts in STANDARD_NOT_RUN.items():
        assert set(parts) <= {p.name for p in get_claim(claim_id).parts}
        assert all(why for why in parts.values())
        assert not_run(claim_id, "standard") == parts
        assert not_run(claim_id, "quick") == not_run(claim_id, "paper") == {}
    assert set(STANDARD_NOT_RUN) == {"GMD-B3", "GMD-F1"}
    assert not_run("GMD-A4", "standard") == {}
    assert not_run("GMD-A3", "standard") == {}
    assert set(not_run("GMD-F1", "standard")) == {"stop_at_20_more_coherent"}
    with pytest.raises(ValueError, match="GMD-A1"):
        not_run("GMD-A1", "standard")
    note = scale_note("standard")
    assert all(claim_id in note.split("Not run at this scale")[1] for claim_id in STANDARD_NOT_RUN)
    assert "input skip" not in note


@pytest.mark.parametrize("notebook", ["01_x0_vs_eps", "06_guidance_schedule"])
def test_notebook_seed_parameters_default_to_the_table(notebook: str) -> None:
    assert notebook_parameters(notebook)["n_seeds"]["default"] == "None"


# ------------------------------------------------------------------------------------------------
# The three scales of GMD's settings (docs/COMPUTE.md §5): each scale's models are
# what the plan says, the paper scale is today's registered full settings (same cache keys),
# and at the standard scale the models the plan aligns are one cache key (the model bank).
# ------------------------------------------------------------------------------------------------

def test_standard_motion_and_trajectory_models_are_the_plans() -> None:
    settings = x0eps.Settings.for_scale("standard")
    for prediction in ("x0", "epsilon"):
        motion = settings.spec("motion", prediction, settings.motion_data())
        assert (motion.base_channels, motion.channel_mults) == (64, (1.0, 1.0))
        training = motion.training
        assert not motion.input_skip and training.autocast is None
        assert motion.caption_draw == "one"      # one caption per window and batch
        assert (training.batch_size, training.lr, training.steps) == (32, 1e-3, 4500)
        assert training.validate_every == 500 and training.patience > 4500 // 500  # no plateau
        assert motion.diffusion_steps == 100 and motion.schedule == "cosine"
        trajectory = settings.spec("trajectory", prediction, settings.data())
        assert (trajectory.base_channels, trajectory.channel_mults) == (32, (1.0, 2.0))
        training = trajectory.training
        assert not trajectory.input_skip and training.autocast is None
        assert (training.batch_size, training.lr, training.steps) == (32, 1e-3, 1000)
        assert training.validate_every == 100 and training.patience > 1000 // 100
        assert trajectory.diffusion_steps == 100
    # a step override keeps the run fixed (the patience outlasts it)
    fields = training_fields("motion", scale="standard", step_cap=1500)
    assert fields["training"].steps == 1500 and fields["training"].patience > 1500 // 500
    assert not settings.longer_eps_run and x0eps.Settings.for_scale("paper").longer_eps_run
    assert x0eps.Settings.for_scale("quick").longer_eps_run  # a test of the paper path
    assert settings.generated == 128


def test_every_standard_model_runs_t_100_and_the_stops_scale() -> None:
    nb02 = rr.Settings.for_scale("standard")
    assert nb02.trajectory_spec("relative", 0).diffusion_steps == 100
    assert nb02.motion_spec("absolute", 0).diffusion_steps == 100
    assert nb02.guidance_stop_t == 2 and nb02.evaluation_windows == 128
    nb03 = emphasis_projection.Settings.for_scale("standard")
    assert nb03.base_spec().diffusion_steps == 100
    assert not nb03.base_spec().input_skip and nb03.base_spec().training.steps == 1500
    assert nb02.motion_spec("absolute", 0).training.steps == 4500
    nb06 = guidance_schedule.Settings.for_scale("standard")
    assert nb06.num_timesteps == 100 and nb06.spec().diffusion_steps == 100
    assert nb06.stops() == {0: 0, 20: 2, 50: 5, 200: 20}
    assert nb06.motion_spec().diffusion_steps == 100


def test_standard_c4_runs_both_matched_values_on_three_seeds() -> None:
    settings = emphasis_projection.Settings.for_scale("standard")
    assert settings.values == (2, 10) and settings.seeds == 3
    assert settings.variants() == [Variant("loss_scaling", 2), Variant("loss_scaling", 10),
                                   Variant("emphasis", 2), Variant("emphasis", 10)]
    outside = settings.outside_rule_variants()
    assert outside == [Variant("emphasis", 10, kind="gaussian", precision="float32_gmd")]
    assert settings.trained_models == 3 * 4
    assert settings.paper_only == ["the orthogonal-matrix arm",
                                   "Table B.1's plain model (k = 1)"]
    paper = emphasis_projection.Settings.for_scale("paper")
    assert paper.paper_only == [] and paper.values == (2, 10) and paper.trained_models == 36


def test_the_standard_model_bank_shares_keys() -> None:
    nb01 = x0eps.Settings.for_scale("standard")
    data = nb01.data(None)
    for seed in (0, 2):
        a4 = nb01.spec("trajectory", "epsilon", data, seed)
        assert a4 == nb01.guidance_trajectory_spec("epsilon", data, seed)
        assert a4 == guidance_trajectory_spec("standard", "epsilon", seed=seed)
        assert a4 == rr.Settings.for_scale("standard").trajectory_spec("absolute", seed)
        assert a4 == guidance_schedule.Settings.for_scale("standard").spec().replace(seed=seed)
        assert (nb01.spec("trajectory", "x0", data, seed)
                == nb01.guidance_trajectory_spec("x0", data, seed))
        # A4's x0 motion model is B3's relative-root x0 text model (sampled with the null
        # text), and its ε model the same spec predicting ε
        a4_x0 = nb01.spec("motion", "x0", nb01.motion_data(), seed)
        assert a4_x0 == rr.Settings.for_scale("standard").motion_spec("relative", seed)
        assert (nb01.spec("motion", "epsilon", nb01.motion_data(), seed)
                == a4_x0.replace(prediction="epsilon"))
        # F1's second stage is B3's absolute-root x0 text model (sampled with the null text)
        assert (guidance_schedule.Settings.for_scale("standard").motion_spec().replace(seed=seed)
                == rr.Settings.for_scale("standard").motion_spec("absolute", seed))
    # one evaluator for notebooks 01, 02 and 03 (``emphasis_projection.experiment``'s
    # ``window_evaluator``)
    steps = emphasis_projection.Settings.for_scale("standard").evaluator_steps
    shared = EvaluatorConfig().replace(steps=steps)
    assert rr.Settings.for_scale("standard").evaluator_config() == shared
    assert nb01.evaluator_config("fingerprint") == EvaluatorConfig().replace(steps=steps)
    # the paper scale keeps A4's T = 100 and A3's T = 1000 trajectory models apart
    paper = x0eps.Settings.for_scale("paper")
    assert (paper.spec("trajectory", "epsilon", paper.data(None))
            != paper.guidance_trajectory_spec("epsilon", paper.data(None)))


def test_paper_scale_is_todays_full_settings() -> None:
    for task, architecture, plan in (
            ("motion", models.MOTION_ARCHITECTURE, models.MOTION_TRAINING),
            ("trajectory", models.TRAJECTORY_ARCHITECTURE, models.TRAJECTORY_TRAINING)):
        assert training_fields(task, scale="paper") == {
            "base_channels": architecture.base_channels,
            "channel_mults": architecture.channel_mults,
            "training": TrainConfig(steps=plan.step_cap, batch_size=plan.batch_size, lr=plan.lr,
                                    validate_every=plan.validate_every, patience=plan.patience,
                                    autocast=plan.autocast, cond_dropout=0.1)}
    nb01 = x0eps.Settings.for_scale("paper")
    motion = nb01.spec("motion", "x0", nb01.motion_data())
    assert motion == GMDModelSpec(task="motion", prediction="x0", data=nb01.motion_data(),
                                  diffusion_steps=100, **training_fields("motion", scale="paper"))
    assert not motion.input_skip and motion.training.autocast == "bfloat16"
    assert (nb01.generated, nb01.guidance_diffusion_steps) == (256, 1000)
    assert nb01.evaluator_config("id") == EvaluatorConfig(data_id="id")
    nb02 = rr.Settings.for_scale("paper")
    assert (nb02.trajectory_diffusion_steps, nb02.guidance_stop_t) == (1000, 20)
    assert nb02.evaluation_windows == 256
    nb03 = emphasis_projection.Settings.for_scale("paper")
    assert (nb03.diffusion_steps, nb03.train_steps) == (50, models.MOTION_TRAINING.step_cap)
    nb06 = guidance_schedule.Settings.for_scale("paper")
    assert nb06.stops() == {0: 0, 20: 20, 50: 50, 200: 200}


@pytest.mark.parametrize("build", [
    lambda s: x0eps.Settings.for_scale(s), lambda s: rr.Settings.for_scale(s),
    lambda s: emphasis_projection.Settings.for_scale(s),
    lambda s: ProjectionSettings.for_scale(s),
    lambda s: guidance_schedule.Settings.for_scale(s)])
def test_an_unknown_scale_is_a_clear_error_where_the_settings_are_made(build, monkeypatch
                                                                       ) -> None:
    """A notebook's settings constructor checks the scale, naming the three, before it asks
    any per-scale table (seeds, models, training)."""
    def no_work(*args: object, **kwargs: object) -> None:
        raise AssertionError("the scale is checked before any work")

    for module in (x0eps.common, rr.common, emphasis_projection.experiment,
                   guidance_schedule.settings):
        for name in ("seeds_of", "training_fields"):
            monkeypatch.setattr(module, name, no_work, raising=False)
    monkeypatch.setattr(models.GuidanceModels, "for_scale", no_work)
    with pytest.raises(ValueError, match="scale must be one of quick, standard, paper"):
        build("full")


@pytest.mark.parametrize("helper", [
    lambda s: training_fields("motion", scale=s, step_cap=10), lambda s: seeds_of("GMD-A3", s),
    lambda s: not_run("GMD-F1", s), scale_note, lambda s: models.GuidanceModels.for_scale(s)])
def test_the_helpers_take_a_checked_scale_and_never_pick_one(helper) -> None:
    """Below the settings constructors a scale is a key of the per-scale tables: an unknown
    one is a KeyError, never another scale's values."""
    with pytest.raises(KeyError):
        helper("full")
