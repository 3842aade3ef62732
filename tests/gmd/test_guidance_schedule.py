"""Notebook 06's helpers: stop-step mapping, per-sample strengths, imputations, obstacles."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch
from conftest import make_context

from repro.claims.ledger import load_sidecars
from repro.claims.registry import get_claim
from repro.claims.result import ClaimResult, Controls, record, recorded_markdown
from repro.claims.verdicts import INCONCLUSIVE, REPRODUCED
from repro.core.diffusion import Guidance
from repro.gmd import settings as rule_settings
from repro.gmd.guidance import goal_reaching_loss, sample
from repro.gmd.guidance_schedule import experiment
from repro.gmd.guidance_schedule.experiment import (
    ScheduleModels,
    SecondStage,
    load_models,
    run_sweeps,
    second_stage,
)
from repro.gmd.guidance_schedule.f1 import F1Study, f1_result
from repro.gmd.guidance_schedule.obstacles import (
    ObstacleSet,
    obstacle_cost,
    obstacle_experiment,
    obstacle_study,
    obstacles_between,
    penetration_depth,
)
from repro.gmd.guidance_schedule.sampling import (
    GMD_NUM_TIMESTEPS,
    model_stop_step,
    point_to_point_imputation,
    shared_start_noise,
    strength_key,
    sweep_strengths,
    weighted_guidance,
    whole_body,
)
from repro.gmd.guidance_schedule.settings import (
    WHOLE_BODY_MEASUREMENTS,
    WHOLE_BODY_PART,
    Settings,
)
from repro.gmd.models import GMDModelSpec, TrainedGMD, load_or_train_gmd, schedule_diffusion
from repro.gmd.settings import not_run
from repro.gmd.windows import DataConfig, load_windows
from repro.standin.dataset import write_dataset

torch.set_num_threads(1)

torch.set_num_threads(1)


FRAMES = 16


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> TrainedGMD:
    root = write_dataset(tmp_path_factory.mktemp("stand_in"), n_clips=10, seed=3)
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(cache))
        spec = GMDModelSpec(task="trajectory", prediction="epsilon",
                            data=DataConfig(data_dir=str(root), frames=FRAMES, stride=8),
                            base_channels=8, channel_mults=(1, 2),
                            diffusion_steps=20).replace(steps=3, batch_size=8)
        return load_or_train_gmd(spec)


GOALS = np.array([[0.5, 1.5], [-1.0, 2.0], [0.0, 0.8]], dtype=np.float32)


def test_stop_step_keeps_gmd_fraction_of_t() -> None:
    assert [model_stop_step(s, 100) for s in (0, 20, 50, 200, 1000)] == [0, 2, 5, 20, 100]
    assert model_stop_step(20, 1000) == 20
    assert model_stop_step(20, 20) == 0  # 0.4 rounds to 0 (quick mode)
    with pytest.raises(ValueError, match="gmd_step"):
        model_stop_step(1001, 100)


def test_strength_key_is_str_of_the_number() -> None:
    assert [strength_key(s) for s in (0, 100.0, 150, 0.5, 1000)] == [
        "0", "100", "150", "0.5", "1000"]


def test_per_sample_strength_equals_separate_strengths(trained: TrainedGMD) -> None:
    # a batch of two identical starts: row b under weights (s1, s2) must equal row b of a run
    # where the whole batch has strength s_b (same shape, so the same per-step noise)
    targets = GOALS[:2]
    goal = goal_reaching_loss(trained.space, targets)
    noise = shared_start_noise(trained, 2, 1, seed=5)
    weighted = sample(trained, 2, seed=5, noise=noise,
                          guidance=weighted_guidance(goal, [3.0, 30.0]), stop_guidance_at=1)
    for row, strength in enumerate((3.0, 30.0)):
        alone = sample(trained, 2, seed=5, noise=noise,
                           guidance=Guidance(goal, strength=strength), stop_guidance_at=1)
        torch.testing.assert_close(weighted[row], alone[row], rtol=1e-4, atol=1e-4)


def test_shared_start_noise_repeats_per_group(trained: TrainedGMD) -> None:
    x = shared_start_noise(trained, 3, 4, seed=1)
    assert x.shape == (12, 4, FRAMES)
    assert torch.equal(x[:3], x[9:]) and not torch.equal(x[0], x[1])


def test_sweep_groups_pair_across_stop_steps(trained: TrainedGMD) -> None:
    a = sweep_strengths(trained, GOALS, [0.0, 10.0], seed=2, stop=0)
    b = sweep_strengths(trained, GOALS, [0.0, 10.0], seed=2, stop=5)
    assert a.samples.shape == (2, 3, 4, FRAMES) and a.goal_error.shape == (2, 3)
    assert a.jerk.shape == (2,) and np.all(a.jerk > 0)
    # strength 0 is unguided whatever the stop step: identical samples, same noise
    torch.testing.assert_close(a.samples[0], b.samples[0])
    assert not torch.allclose(a.samples[1], b.samples[1])
    assert a.mean_goal_error(0) == pytest.approx(float(a.goal_error[0].mean()))
    with pytest.raises(KeyError):
        a.index(7.0)


def test_goal_keypoint_imputation_to_the_end_lands_on_the_goal(trained: TrainedGMD) -> None:
    sweep = sweep_strengths(trained, GOALS, [0.0], seed=0, stop=0, impute_goal=True)
    assert sweep.goal_error.max() < 1e-4
    stopped = sweep_strengths(trained, GOALS, [0.0], seed=0, stop=3, impute_goal=True)
    assert stopped.goal_error.max() > 1e-4  # the last three steps are free


def test_point_to_point_imputation_is_the_straight_line(trained: TrainedGMD) -> None:
    imputation = point_to_point_imputation(trained, GOALS, active=[True, False, True])
    assert imputation.mask[1].sum() == 0 and imputation.mask[0, 1:3].all()
    assert not imputation.mask[0, [0, 3]].any()
    path = trained.space.root_xz(imputation.target)
    np.testing.assert_allclose(path[0, 0].numpy(), [0.0, 0.0], atol=1e-5)
    np.testing.assert_allclose(path[0, -1].numpy(), GOALS[0], atol=1e-5)
    np.testing.assert_allclose(path[2, FRAMES // 2].numpy(),
                               GOALS[2] * (FRAMES // 2) / (FRAMES - 1), atol=1e-5)


def test_obstacles_block_the_line_but_not_the_ends() -> None:
    targets = np.array([[0.0, 1.0], [3.0, 4.0]], dtype=np.float32)
    obstacles = obstacles_between(targets)
    np.testing.assert_allclose(obstacles.centres, [[0.0, 0.5], [1.5, 2.0]])
    np.testing.assert_allclose(obstacles.radii, [0.3, 0.4])
    distance = np.linalg.norm(targets, axis=1)
    clearance = np.linalg.norm(obstacles.centres, axis=1) - obstacles.radii  # start and goal
    assert np.all(clearance >= 0.2 * distance - 1e-6)
    with pytest.raises(ValueError):
        ObstacleSet(np.zeros((2, 2)), np.zeros(3))


def test_penetration_and_cost_of_a_straight_path(trained: TrainedGMD) -> None:
    line = point_to_point_imputation(trained, GOALS).target
    obstacles = obstacles_between(GOALS)
    depth = penetration_depth(trained.space, line, obstacles)
    # the line passes (near) the centre: depth ≈ radius (frames are discrete)
    assert np.all(depth > 0.8 * obstacles.radii) and np.all(depth <= obstacles.radii + 1e-6)
    x = line.clone().requires_grad_(True)
    cost = obstacle_cost(trained.space, obstacles)(x)
    assert cost.shape == (3,) and torch.all(cost > 0)
    cost.sum().backward()
    assert x.grad[:, 1:3].abs().sum() > 0 and x.grad[:, [0, 3]].abs().sum() == 0


def test_obstacle_experiment_arms(trained: TrainedGMD) -> None:
    arms = obstacle_experiment(trained, GOALS, obstacles_between(GOALS), [10.0],
                                  seed=0, stop=0)
    assert [a.label for a in arms] == ["unguided", "goal, s=10", "goal + obstacle, s=10",
                                       "goal + obstacle + p2p, s=10"]
    for arm in arms:
        assert arm.samples.shape == (3, 4, FRAMES) and arm.goal_error.shape == (3,)
        assert 0.0 <= arm.collision_rate <= 1.0 and arm.jerk > 0
    p2p = arms[-1]
    # the straight line imputed up to t = 0 ends on the goal and goes through the obstacle
    assert p2p.goal_error.max() < 1e-4 and p2p.collision_rate == 1.0


def test_recorded_steps_show_where_guidance_acts(trained: TrainedGMD) -> None:
    sweep = sweep_strengths(trained, GOALS, [0.0, 10.0], seed=0, stop=4, record_steps=True)
    steps = trained.num_timesteps
    assert sweep.timesteps.tolist() == list(range(steps - 1, -1, -1))
    assert sweep.shift_size.shape == (steps, 2) and sweep.state_size.shape == (steps, 2)
    assert np.all(sweep.shift_size[:, 0] == 0)            # strength 0 never shifts
    assert np.all(sweep.shift_size[sweep.timesteps < 4, 1] == 0)   # nor below the stop step
    # active from t = T−1 down to the stop (x̂0 may be clamped everywhere at t = T−1: no gradient)
    active = (sweep.timesteps >= 4) & (sweep.timesteps < steps - 1)
    assert np.all(sweep.shift_size[active, 1] > 0)


def test_settings_share_notebook_01s_guidance_trajectory_model() -> None:
    from repro.gmd.x0_vs_eps import Settings as Notebook01Settings

    for scale in ("quick", "standard", "paper"):
        settings = Settings.for_scale(scale)
        model = Notebook01Settings.for_scale(scale)
        assert settings.models == model.models
        assert settings.spec() == model.guidance_trajectory_spec("epsilon", model.data(None))
        assert settings.motion_spec() == model.spec("motion", "x0", model.data(None)).replace(
            text_conditioned=scale != "paper")
    full = Settings.for_scale("paper")
    assert full.num_timesteps == 1000 and full.gmd_stop == 20
    assert full.stops() == {0: 0, 20: 20, 50: 50, 200: 200}  # GMD's own steps, no mapping
    assert set(full.rule_strengths) <= set(full.strengths) and 0 in full.strengths
    assert Settings.for_scale("quick").stops() == {0: 0, 20: 1, 50: 2, 200: 10}  # T = 50


@pytest.fixture(scope="module")
def motion(tmp_path_factory: pytest.TempPathFactory) -> TrainedGMD:
    root = write_dataset(tmp_path_factory.mktemp("stand_in_motion"), n_clips=10, seed=3)
    cache = tmp_path_factory.mktemp("cache_motion")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(cache))
        spec = GMDModelSpec(task="motion", prediction="x0",
                            data=DataConfig(data_dir=str(root), frames=FRAMES, stride=8),
                            base_channels=8, channel_mults=(1, 2),
                            diffusion_steps=10).replace(steps=3, batch_size=8)
        return load_or_train_gmd(spec)


def test_second_stage_puts_the_body_on_the_imputed_trajectory(trained: TrainedGMD,
                                                              motion: TrainedGMD) -> None:
    sweep = sweep_strengths(trained, GOALS, [10.0], seed=0, stop=0)
    trajectories = sweep.samples[0]
    body = whole_body(motion, trained.space, trajectories, GOALS, seed=0, gmd_stop=0)
    assert body.motions.shape == (3, 263, FRAMES) and body.motion_stop == 0
    np.testing.assert_allclose(motion.space.root_positions(body.motions),
                               trained.space.root_positions(trajectories), atol=1e-4)
    np.testing.assert_allclose(body.goal_error, sweep.goal_error[0], atol=1e-4)
    assert body.joint_jerk > 0
    # GMD's stop t = 20 of 1000 is 2 % of the motion model's T = 10: round(0.2) = 0 steps free;
    # stop 200 of 1000 leaves the last 2 steps free, so the root may leave the imputed path
    free = whole_body(motion, trained.space, trajectories, GOALS, seed=0, gmd_stop=200)
    assert free.motion_stop == 2
    assert not torch.allclose(free.motions[:, :4], body.motions[:, :4], atol=1e-4)


# ------------------------------------------------------------------------------------------------
# Notebook 06's experiment as library calls: the sweeps over seeds, the stop reading, GMD's
# second stage and the obstacle extra gather the rule's per-seed lists, and ``f1_result`` is a
# ClaimResult that records them with the run's guidance settings.
# ------------------------------------------------------------------------------------------------

torch.set_num_threads(1)


#: the keys of extra["parameters"] in every sidecar of notebooks 01 and 06
PARAMETER_KEYS = {"num_timesteps", "guidance_stop_t", "x0_clamp"}


@pytest.fixture(scope="module")
def loaded(tmp_path_factory: pytest.TempPathFactory) -> ScheduleModels:
    root = write_dataset(tmp_path_factory.mktemp("stand_in"), n_clips=10, seed=3)
    data = DataConfig(data_dir=str(root), frames=FRAMES, stride=8)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("REPRO_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        spec = GMDModelSpec(task="trajectory", prediction="epsilon", data=data, base_channels=8,
                            channel_mults=(1, 2), diffusion_steps=20).replace(steps=3,
                                                                              batch_size=8)
        motion_spec = GMDModelSpec(task="motion", prediction="x0", data=data, base_channels=8,
                                   channel_mults=(1, 2), diffusion_steps=10).replace(
                                       steps=3, batch_size=8)
        model, motion = load_or_train_gmd(spec), load_or_train_gmd(motion_spec)
    train = load_windows(data)   # also the goals' windows: the small set has few test clips
    stops = {g: model_stop_step(g, 20) for g in (0, 20, 50, 200)}
    return ScheduleModels(
        spec, motion_spec, train, train, {0: model}, {0: motion}, [False, False], stops,
        model.diffusion.alphas_cumprod,
        schedule_diffusion("cosine", GMD_NUM_TIMESTEPS).alphas_cumprod)


def _settings() -> Settings:
    quick = Settings.for_scale("quick", seeds=1)
    return dataclasses.replace(quick, goals=3, obstacle_goals=2, strengths=(0, 3, 100, 150, 200),
                               models=dataclasses.replace(quick.models, min_goal_distance=0.0))


def test_the_experiment_returns_the_rules_lists_and_records_them(
        loaded: ScheduleModels, tmp_path: Path) -> None:
    settings = _settings()
    sweeps = run_sweeps(loaded, settings, [0], log=lambda _: None)
    assert set(sweeps.goal_by_s) == {"0", "3", "100", "150", "200"}
    assert sweeps.goal_by_s["100"] == [sweeps.sweep[0].mean_goal_error(100)]
    assert "**(claimed range)**" in sweeps.strength_table(settings)
    stop = sweeps.stop_reading(settings)
    assert stop.rule_arm == "guidance, s = 100" and set(stop.goal) == {
        "guidance, s = 3", "guidance, s = 100", "guidance + goal imputation, s = 100"}
    assert stop.jerk[stop.rule_arm][20] == [sweeps.stop_sweep[(0, 20)].mean_jerk(100)]
    body = second_stage(loaded, sweeps, settings)
    assert set(body.coherence["joint_jerk"]) == {0, 20}
    assert f"stop at t = {loaded.stops[20]} of 20" in body.table(loaded, [0])
    obstacles = obstacle_study(loaded, sweeps, settings)
    assert obstacles.s_lowest in (3, 100, 150, 200) and 100 in obstacles.strengths
    study = F1Study(loaded, sweeps, stop, body, obstacles, first_step={3: 0.1},
                    peak_state={3: 1.0})
    result = f1_result(study, settings, controls=Controls(null={}, positive={}),
                       timings={"sweeps": 1.23}, model_records=[])
    assert result.claim_id == "GMD-F1" and result.seeds == [0]
    assert set(result.extra["parameters"]) == PARAMETER_KEYS
    assert result.extra["parameters"]["guidance_stop_t"] == loaded.stops[20]
    assert result.measured["goal_error_stop_20"] == stop.goal[stop.rule_arm][20]
    assert result.extra["timings_s"] == {"sweeps": 1.2}
    # recorded without controls: the rule decides the lists as they are
    recorded = record(make_context(tmp_path), dataclasses.replace(result, controls=None))
    sidecar = load_sidecars(tmp_path / "claims")["GMD-F1"]
    assert sidecar["measured"]["jitter_unguided"] == sweeps.jerk_by_s["0"]
    shown = recorded_markdown(make_context(tmp_path), recorded)
    assert shown.startswith("**GMD-F1 — ") and "**GMD-F1 controls**" not in shown


# ------------------------------------------------------------------------------------------------
# The standard scale registers GMD-F1's whole-body part as not run (gmd.settings.not_run): no
# second stage, no motion model, and the part recorded "not run at the standard scale: why".
# ------------------------------------------------------------------------------------------------

WHY = not_run("GMD-F1", "standard")[WHOLE_BODY_PART]


def test_only_the_standard_scale_skips_the_second_stage() -> None:
    for scale in ("quick", "paper"):
        settings = Settings.for_scale(scale)
        assert settings.runs_second_stage and settings.f1_not_run == {}
        with pytest.raises(ValueError, match="runs the second stage"):
            settings.second_stage_note()
    standard = Settings.for_scale("standard")
    assert not standard.runs_second_stage
    assert standard.f1_not_run == {WHOLE_BODY_PART: WHY}
    assert standard.second_stage_note() == (
        f"**Not run at the standard scale** (GMD-F1's part `{WHOLE_BODY_PART}`): {WHY}.")
    part = {p.name: p for p in get_claim("GMD-F1").parts}[WHOLE_BODY_PART]
    assert set(part.needs) == set(WHOLE_BODY_MEASUREMENTS)


def test_load_models_asks_for_no_motion_model_without_the_second_stage(
        trained: TrainedGMD, loaded: ScheduleModels, monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[list[GMDModelSpec]] = []

    def load_or_train_many(specs: list[GMDModelSpec], train: object,
                           device: object) -> list[TrainedGMD]:
        asked.append(list(specs))
        return [trained] * len(specs)

    monkeypatch.setattr(experiment, "load_windows", lambda *args, **kwargs: loaded.train)
    monkeypatch.setattr(experiment, "is_cached", lambda spec, train: False)
    monkeypatch.setattr(experiment, "load_or_train_many", load_or_train_many)
    standard = load_models(Settings.for_scale("standard"), [0, 1, 2])
    assert [(s.task, s.training.seed) for s in asked[-1]] == [("trajectory", s) for s in (0, 1, 2)]
    assert standard.motion_spec is None and standard.motion_models == {}
    assert len(standard.was_cached) == 3
    shown = dataclasses.replace(standard, stops={0: 0}).summary()   # the stand-in has T = 20
    assert "second stage: no motion model (not run at this scale)" in shown
    quick = load_models(Settings.for_scale("quick"), [0])
    assert [s.task for s in asked[-1]] == ["trajectory", "motion"]
    assert set(quick.motion_models) == {0} and quick.motion_spec is not None


def test_f1_without_the_second_stage_records_that_part_as_not_run(
        loaded: ScheduleModels, tmp_path: Path) -> None:
    quick = _settings()
    standard = dataclasses.replace(quick, scale="standard")
    sweeps = run_sweeps(loaded, standard, [0], log=lambda _: None)
    stop = sweeps.stop_reading(standard)
    assert second_stage(loaded, sweeps, standard) is None
    obstacles = obstacle_study(loaded, sweeps, standard)
    common = dict(controls=Controls(null={}, positive={}), timings={}, model_records=[])

    def study(body: SecondStage | None) -> F1Study:
        return F1Study(loaded, sweeps, stop, body, obstacles, first_step={3: 0.1},
                       peak_state={3: 1.0})

    result = f1_result(study(None), standard, **common)
    assert result.not_run == {WHOLE_BODY_PART: WHY}
    assert not set(WHOLE_BODY_MEASUREMENTS) & set(result.measured)
    assert result.measured["goal_error_stop_20"] == stop.goal[stop.rule_arm][20]
    assert result.headline.endswith("whole body: not run at the standard scale")
    assert "joint jerk" not in result.headline and WHY in result.notes
    assert not {"motion_stop_steps", "whole_body_goal_error"} & set(result.extra)
    with pytest.raises(ValueError, match="does not run GMD's second stage"):
        f1_result(study(SecondStage({}, {}, {})), standard, **common)
    with pytest.raises(ValueError, match="runs GMD's second stage; got no"):
        f1_result(study(None), quick, **common)
    record(make_context(tmp_path, scale="standard"), dataclasses.replace(result, controls=None))
    sidecar = load_sidecars(tmp_path / "claims")["GMD-F1"]
    assert sidecar["not_run"] == {WHOLE_BODY_PART: f"not run at the standard scale: {WHY}"}


def test_f1_recorded_without_the_whole_body_decides_the_rest_and_its_controls(
        tmp_path: Path) -> None:
    """The registry's example measurements without the second stage's: the whole-body part
    is "not run at the standard scale: why", the other parts and the controls are decided
    over the parts that run."""
    claim, rng = get_claim("GMD-F1"), np.random.default_rng(0)

    def without_body(measured: dict) -> dict:
        return {k: v for k, v in measured.items() if k not in WHOLE_BODY_MEASUREMENTS}

    settings = Settings.for_scale("standard")
    result = ClaimResult(
        "GMD-F1", without_body(claim.example_at(rng, 1.0, 3)), seeds=[0, 1, 2],
        settings={**rule_settings.f1(settings), "seeds": 3},
        controls=Controls(null=without_body(claim.example_at(rng, 0.0, 3)),
                          positive=without_body(claim.example_at(rng, 4.0, 3))),
        not_run=settings.f1_not_run)
    recorded = record(make_context(tmp_path, scale="standard"), result)
    parts = {p.name: p for p in recorded.decision.parts}
    assert parts[WHOLE_BODY_PART].outcome == INCONCLUSIVE
    assert parts[WHOLE_BODY_PART].reason == f"not run at the standard scale: {WHY}"
    assert all(p.reason != parts[WHOLE_BODY_PART].reason
               for name, p in parts.items() if name != WHOLE_BODY_PART)
    assert recorded.verdict != REPRODUCED            # a part not run is never reproduced
    assert recorded.controls["positive"]["status"] == "passed"
    assert recorded.controls["positive"]["verdict"] == REPRODUCED   # over the parts that run
    assert recorded.controls["null"]["status"] == "passed"
