"""Notebook 06 (GMD appendix F): guidance strength s and the stop step (claim GMD-F1).

GMD (appendix F) guides its ε trajectory model with goal functions on x̂0,
μ̃ = μ − s·Σ_t·∇_{x_t}G(x̂0), with s = 100 ("performs well within the range of 100 to 200"),
imputes where feasible, and stops both at t = 20 of T = 1000 "as this led to a slight
improvement in the motion coherence". For obstacle avoidance it drops point-to-point
imputation, which could lead through an obstacle.

The modules, from the bottom up (each imports only those before it):

- ``sampling``: the samplers on top of ``repro.gmd.guidance``: GMD's stop step on another T
  (``model_stop_step``), one sampling call for many strengths (``sweep_strengths``), GMD's two
  imputations, and GMD's second stage (``whole_body``: the x0 motion model with a guided
  trajectory imputed into its root channels);
- ``settings``: notebook 06's ``Settings`` (every grid and size; the models are notebook 01's,
  the scale's ``gmd.models.GuidanceModels``) and GMD-F1's whole-body part, which decides
  whether a scale runs the second stage;
- ``experiment``: the models (``load_models``), the strength and stop sweeps over the seeds
  (``run_sweeps``) and the second stage over them (``second_stage``), with their tables;
- ``obstacles``: the obstacle extra (outside the rule): circular obstacles, their sampler and
  the study over the seeds (``obstacle_study``);
- ``plots``: the notebook's figures;
- ``f1``: the claim GMD-F1: its planted and A/A controls, the models' gate records and its
  result (``f1_result`` of an ``F1Study``).

The package re-exports the names notebook 06 and the tests' shared fixtures (``Settings``)
use; everything else is imported from its module.
"""

from repro.gmd.guidance_schedule.experiment import load_models, run_sweeps, second_stage
from repro.gmd.guidance_schedule.f1 import (
    F1Study,
    f1_aa_controls,
    f1_result,
    motion_records,
    trajectory_records,
)
from repro.gmd.guidance_schedule.obstacles import obstacle_study
from repro.gmd.guidance_schedule.plots import (
    plot_example_paths,
    plot_guidance_per_step,
    plot_obstacles,
    plot_stop_sweep,
    plot_strength_sweep,
    plot_whole_body_stop,
)
from repro.gmd.guidance_schedule.settings import Settings

__all__ = ["F1Study", "Settings", "f1_aa_controls", "f1_result", "load_models", "motion_records",
           "obstacle_study", "plot_example_paths", "plot_guidance_per_step", "plot_obstacles",
           "plot_stop_sweep", "plot_strength_sweep", "plot_whole_body_stop", "run_sweeps",
           "second_stage", "trajectory_records"]
