"""Notebook 06's settings: every grid and size of the run (``Settings``), and GMD-F1's part
that reads GMD's second stage (``WHOLE_BODY_PART``), which decides whether a scale runs it.

The models are notebook 01's: the trajectory ε model is its guidance model and the second
stage's motion model its x0 motion spec, both from the scale's ``gmd.models.GuidanceModels``
(held in ``Settings.models``; one cache key with notebook 01's).
"""

from __future__ import annotations

from dataclasses import dataclass

from repro.gmd import settings as rule_settings
from repro.gmd.guidance_schedule.sampling import model_stop_step
from repro.gmd.models import GUIDANCE_STOP_T, GMDModelSpec, GuidanceModels
from repro.gmd.settings import seeds_of
from repro.gmd.windows import DataDir
from repro.infra.context import RunSettings, check_scale

__all__ = ["Settings", "WHOLE_BODY_MEASUREMENTS", "WHOLE_BODY_PART"]

#: GMD-F1's part that reads the second stage (whole-body coherence), and only that part
WHOLE_BODY_PART = "stop_at_20_more_coherent"

#: the measurements of ``WHOLE_BODY_PART``: joint jerk and foot skating at GMD's stops 0 and 20
WHOLE_BODY_MEASUREMENTS = ("joint_jerk_stop_0", "joint_jerk_stop_20", "foot_skating_stop_0",
                           "foot_skating_stop_20")


@dataclass(frozen=True)
class Settings(RunSettings):
    """Every grid and size of notebook 06, fixed before any verdict was seen.

    The trajectory ε model is notebook 01's guidance model (``models``, the scale's
    ``gmd.models.GuidanceModels``: GMD's T = 1000 cosine, one cache key with GMD-A3's), the
    second stage's motion model an x0 motion model with notebook 01's sizes on GMD's
    absolute-root windows (``motion_spec``; GMD-A4's own motion models are relative-root, so
    it is not one of theirs; below the paper scale it is notebook 02's text-conditioned B3
    model, sampled with the null condition). ``strengths``
    draw the curve, ``rule_strengths`` are the claimed range the rule reads; ``gmd_stops``
    are GMD's stop steps of T = 1000, which are the model's own at T = 1000 (quick mode's
    T = 50 takes the same fraction, :func:`model_stop_step`); the stop sweep runs at
    ``stop_sweep_strengths``. Quick mode shrinks the model and the goal counts (a test of
    the code, never a result). A scale that registers GMD-F1's whole-body part as not run
    (``gmd.settings.not_run``: the standard scale) runs no second stage
    (``runs_second_stage``): its motion model is neither trained nor loaded.
    """

    scale: str
    seeds: int
    goals: int
    obstacle_goals: int
    models: GuidanceModels
    strengths: tuple[int, ...] = (0, 1, 3, 10, 30, 100, 150, 200, 300, 1000)
    rule_strengths: tuple[int, ...] = (100, 150, 200)
    #: GMD's s, at which the rule compares the stop steps.
    gmd_strength: int = 100
    gmd_stops: tuple[int, ...] = (0, 20, 50, 200)
    #: GMD's stop step t = 20 (of 1000).
    gmd_stop: int = GUIDANCE_STOP_T
    stop_sweep_strengths: tuple[int, ...] = (3, 100)
    obstacle_weight: float = 1.0
    #: goals whose guided paths the example figures draw.
    goals_shown: int = 6

    @classmethod
    def for_scale(cls, scale: str, *, seeds: int | None = None) -> Settings:
        """The settings of ``scale`` (``seeds`` None: ``settings.seeds_of("GMD-F1", scale)``).
        At the standard scale the models are notebook 01's at T = 100, and ``stops`` maps
        GMD's {0, 20, 50, 200} of 1000 to {0, 2, 5, 20}."""
        scale = check_scale(scale)
        seeds = seeds_of("GMD-F1", scale) if seeds is None else int(seeds)
        models = GuidanceModels.for_scale(scale)
        goals = {"quick": (4, 4), "standard": (32, 16), "paper": (32, 16)}[scale]
        return cls(scale=scale, seeds=seeds, goals=goals[0], obstacle_goals=goals[1],
                   models=models)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def num_timesteps(self) -> int:
        """T of the trajectory model (GMD's 1000; standard 100; quick 50)."""
        return self.models.guidance_diffusion_steps

    def spec(self, data_dir: DataDir = None) -> GMDModelSpec:
        """Notebook 01's guidance ε trajectory model (seed 0; ``replace(seed=…)`` per seed)."""
        return self.models.guidance_trajectory_spec("epsilon", self.models.data(data_dir))

    def motion_spec(self, data_dir: DataDir = None) -> GMDModelSpec:
        """GMD's second stage (seed 0): notebook 01's x0 motion spec on its absolute-root
        windows, where the trajectory's root x/z is imputed. Below the paper scale it is
        text-conditioned — at the standard scale exactly notebook 02's GMD-B3 absolute-root
        model (``root_representation.Settings.motion_spec``, one cache key; docs/COMPUTE.md
        §3d) — and ``whole_body`` samples it with the null condition (``guidance.sample``
        without text); the paper scale keeps today's unconditional model."""
        spec = self.models.spec("motion", "x0", self.models.data(data_dir))
        return spec if self.scale == "paper" else spec.replace(text_conditioned=True)

    def stops(self) -> dict[int, int]:
        """{GMD stop step: the trajectory model's stop step} for ``gmd_stops``."""
        return {g: model_stop_step(g, self.num_timesteps) for g in self.gmd_stops}

    @property
    def f1_not_run(self) -> dict[str, str]:
        """GMD-F1's parts this scale does not run, each with why (``gmd.settings.not_run``:
        registered before the run; ``ClaimResult.not_run`` takes it)."""
        return rule_settings.not_run("GMD-F1", self.scale)

    @property
    def runs_second_stage(self) -> bool:
        """Whether this scale runs GMD's second stage (``motion_spec``, ``whole_body``): not
        where the only part that reads it, ``WHOLE_BODY_PART``, is registered as not run."""
        return WHOLE_BODY_PART not in self.f1_not_run

    def second_stage_note(self) -> str:
        """A markdown line for a scale that does not run the second stage: the part it would
        decide and the registered reason, as the ledger records it."""
        if self.runs_second_stage:
            raise ValueError(f"the {self.scale} scale runs the second stage")
        return (f"**Not run at the {self.scale} scale** (GMD-F1's part `{WHOLE_BODY_PART}`): "
                f"{self.f1_not_run[WHOLE_BODY_PART]}.")
