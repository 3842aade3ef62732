"""Notebook 06's experiment as library calls: the sweeps over seeds, the stop reading, GMD's
second stage and the obstacle extra gather the rule's per-seed lists, and ``f1_result`` is a
ClaimResult that records them with the run's guidance settings (issue #17, issue #34)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch
from conftest import make_context

from repro.claims.ledger import load_sidecars
from repro.claims.result import Controls, record, recorded_markdown
from repro.gmd import guidance_schedule as gs
from repro.gmd.models import GMDModelSpec, load_or_train_gmd, schedule_diffusion
from repro.gmd.windows import DataConfig, load_windows
from repro.standin.dataset import write_dataset

torch.set_num_threads(1)
FRAMES = 16
#: the keys of extra["parameters"] in every sidecar of notebooks 01 and 06 (issue #17)
PARAMETER_KEYS = {"num_timesteps", "guidance_stop_t", "x0_clamp"}


@pytest.fixture(scope="module")
def loaded(tmp_path_factory: pytest.TempPathFactory) -> gs.ScheduleModels:
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
    stops = {g: gs.model_stop_step(g, 20) for g in (0, 20, 50, 200)}
    return gs.ScheduleModels(
        spec, motion_spec, train, train, {0: model}, {0: motion}, [False, False], stops,
        model.diffusion.alphas_cumprod,
        schedule_diffusion("cosine", gs.GMD_NUM_TIMESTEPS).alphas_cumprod)


def _settings() -> gs.Settings:
    quick = gs.Settings.for_scale("quick", seeds=1)
    return dataclasses.replace(quick, goals=3, obstacle_goals=2, strengths=(0, 3, 100, 150, 200),
                               model=dataclasses.replace(quick.model, min_goal_distance=0.0))


def test_the_experiment_returns_the_rules_lists_and_records_them(
        loaded: gs.ScheduleModels, tmp_path: Path) -> None:
    settings = _settings()
    sweeps = gs.run_sweeps(loaded, settings, [0], log=lambda _: None)
    assert set(sweeps.goal_by_s) == {"0", "3", "100", "150", "200"}
    assert sweeps.goal_by_s["100"] == [sweeps.sweep[0].mean_goal_error(100)]
    assert "**(claimed range)**" in sweeps.strength_table(settings)
    stop = sweeps.stop_reading(settings)
    assert stop.rule_arm == "guidance, s = 100" and set(stop.goal) == {
        "guidance, s = 3", "guidance, s = 100", "guidance + goal imputation, s = 100"}
    assert stop.jerk[stop.rule_arm][20] == [sweeps.stop_sweep[(0, 20)].mean_jerk(100)]
    body = gs.second_stage(loaded, sweeps, settings)
    assert set(body.coherence["joint_jerk"]) == {0, 20}
    assert f"stop at t = {loaded.stops[20]} of 20" in body.table(loaded, [0])
    obstacles = gs.obstacle_study(loaded, sweeps, settings)
    assert obstacles.s_lowest in (3, 100, 150, 200) and 100 in obstacles.strengths
    result = gs.f1_result(
        loaded, sweeps, stop, body, obstacles, settings,
        controls=Controls(null={}, positive={}), first_step={3: 0.1},
        peak_state={3: 1.0}, timings={"sweeps": 1.23}, model_records=[])
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
