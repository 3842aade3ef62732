"""The notebook figures draw from measured values alone (smoke tests on small inputs)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from repro.gmd import (
    figures,
    guidance_schedule,  # noqa: E402
)
from repro.gmd.guidance_schedule.sampling import strength_key  # noqa: E402
from repro.gmd.models import schedule_diffusion
from repro.gmd.x0_vs_eps.a1 import posterior_mean_forms, printed_c_relative_error
from repro.gmd.x0_vs_eps.a2 import coefficient_shares, peak_fraction


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def test_appendix_a_figures() -> None:
    diffusion = schedule_diffusion("cosine", 50)
    fig = figures.plot_posterior_mean_forms(posterior_mean_forms(diffusion, samples=4),
                                            printed_c_relative_error(diffusion), draws=4)
    assert len(fig.axes) == 2
    schedules = {name: coefficient_shares(schedule_diffusion(name, 50))
                 for name in ("cosine", "linear")}
    peaks = {name: {k: peak_fraction(v[k]) for k in ("x0_share", "eps_share")}
             for name, v in schedules.items()}
    fig = figures.plot_coefficient_shares(schedules, peaks)
    assert len(fig.axes) == 4 and "peaks at t = 1 (x0)" in fig.axes[2].get_title()


def test_sample_quality_and_filmstrips() -> None:
    values = {f"{k}_{tag}": [1.0, 2.0] for k in ("motion_jitter", "motion_fid",
                                                 "trajectory_jitter") for tag in ("x0", "eps")}
    fig = figures.plot_sample_quality(values, {"motion_jitter": 1.0, "motion_fid": 0.5,
                                               "trajectory_jitter": 2.0})
    assert len(fig.axes) == 3
    joints = np.random.default_rng(0).normal(size=(12, 22, 3))
    assert len(figures.plot_filmstrips({"a": joints, "b": joints}, frames=4).axes) == 2


def test_guidance_schedule_figures() -> None:
    strengths, seeds = [0, 10, 100], [0, 1]
    per_seed = {strength_key(s): [1.0 + s, 2.0 + s] for s in strengths}
    fig = guidance_schedule.plot_strength_sweep(per_seed, per_seed, strengths, seeds, stop=2,
                                                num_timesteps=100)
    assert "t ≥ 2 of T = 100" in fig.axes[0].get_title()
    stops = {0: 0, 20: 2}
    table = {"arm": {0: [1.0, 2.0], 20: [1.5, 2.5]}}
    assert len(guidance_schedule.plot_stop_sweep(table, table, stops, seeds).axes) == 3
    body = {"joint_jerk": {0: [60.0, 70.0], 20: [58.0, 69.0]},
            "foot_skating": {0: [0.5, 0.6], 20: [0.45, 0.58]}}
    fig = guidance_schedule.plot_whole_body_stop(body, seeds, stops={0: 0, 20: 20},
                                                 num_timesteps=1000)
    assert len(fig.axes) == 2 and "t = 20\nof 1000" in fig.axes[0].get_xticklabels()[1].get_text()
