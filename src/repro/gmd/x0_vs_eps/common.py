"""What notebook 01's claims share: its :class:`Settings`, the arms and the trajectory gates.

- :class:`Settings`: every size and step count of notebook 01 at one scale (the scale is
  checked here, in :meth:`Settings.for_scale`), and :func:`guidance_trajectory_spec`, the
  trajectory model every guidance experiment shares (GMD-A3 here, GMD-B2 in notebook 02,
  GMD-F1 in notebook 06: one cache key);
- the two parametrisations (``PREDICTIONS``), GMD-A4's registered parts (``A4_PARTS``, which
  the settings read to know which motion arms a scale trains), the figure-path type of the
  results;
- each prediction's role in GMD-A3 and A4 and the ``gmd_trajectory`` gate values both claims'
  trajectory models are recorded with.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Literal

from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    MIN_GOAL_DISTANCE,
    GMDModelSpec,
    GuidanceModels,
    TrainedGMD,
)
from repro.gmd.settings import seeds_of
from repro.gmd.windows import (
    DataConfig,
    DataDir,
    MotionWindows,
    Representation,
    Task,
)
from repro.infra.context import RunSettings, check_scale
from repro.models.evaluator import EvaluatorConfig
from repro.motion.usability import WindowNeeds


@dataclass(frozen=True)
class Settings(RunSettings):
    """Every size and step count of notebook 01 at one scale, fixed before any verdict was seen.

    Paper scale (today's registered full settings): 48-frame windows (stride 24) of the
    2000-clip stand-in set, one UNet1D per task for x0 and ε (``models``'
    architectures), T = 100 cosine, trained to convergence up to each family's step cap
    (``models.training_fields``); 32 goals and 256 generated windows per seed; the package's
    evaluator with its default size; the guidance experiments' trajectory models (GMD-A3, B2,
    F1) the same trajectory specs with ``guidance_diffusion_steps`` = GMD's T = 1000; and
    GMD-A4's longer ε run (``longer_eps_run``). Standard scale (``make reproduce``,
    docs/COMPUTE.md §3): the same windows, the standard architectures at a fixed step count
    (``models.training_fields``), T = 100 for every model — so A4's trajectory models *are*
    A3's guidance models (one cache key) — 128 generated windows per seed, the evaluator of
    notebooks 02 and 03 (one key), no longer ε run. Quick scale shrinks everything (a test of
    the code, never a result; guidance T = ``models.QUICK_GUIDANCE_DIFFUSION_STEPS``, 50).
    ``train_steps`` may be overridden (the notebook's papermill parameter; None = the scale's).

    The trajectory models train on absolute-root windows (GMD's trajectory model: root x/z in
    the world); GMD-A4's motion models on ``motion_representation``, HumanML3D's relative root
    (:meth:`motion_data`): the claim is about MDM's ε model of ε ∈ R^{263×M}, and MDM models
    HumanML3D's features as they are (GMD-A4's registry entry).
    """

    scale: str
    seeds: int
    stand_in_clips: int
    frames: int
    #: the step cap (quick) or count (standard); None: each family's (``training_fields``)
    train_steps: int | None
    batch_size: int
    diffusion_steps: int
    goals: int
    generated: int
    #: goals are end positions of test windows whose root travels at least this far (m).
    min_goal_distance: float = MIN_GOAL_DISTANCE
    #: random draws of x_t and ε per t for the Eq. 1 vs Eq. 2 check (GMD-A1).
    posterior_samples: int = 256
    #: T of the guidance experiments' trajectory models (GMD's 1000; standard 100; quick 50).
    guidance_diffusion_steps: int = GUIDANCE_DIFFUSION_STEPS
    #: the root representation of GMD-A4's motion windows (MDM's: HumanML3D's relative root)
    motion_representation: Representation = "relative"
    #: the evaluator's training steps at the standard scale (``emphasis_projection``'s and
    #: notebook 02's: one cache key); None: the scale's own evaluator
    shared_evaluator_steps: int | None = None

    @classmethod
    def for_scale(cls, scale: str, *, seeds: int | None = None,
                  train_steps: int | None = None) -> Settings:
        """The settings of ``scale`` (checked here, once); ``seeds`` (None:
        ``settings.seeds_of("GMD-A4", scale)``) and ``train_steps`` (None: the scale's)
        override. The models' sizes are the scale's ``models.GuidanceModels``."""
        scale = check_scale(scale)
        seeds = seeds_of("GMD-A4", scale) if seeds is None else int(seeds)
        models = GuidanceModels.for_scale(scale, train_steps=train_steps)
        shared = {"scale": scale, "seeds": seeds, "stand_in_clips": models.stand_in_clips,
                  "frames": models.frames, "train_steps": models.train_steps,
                  "batch_size": models.batch_size, "diffusion_steps": models.diffusion_steps,
                  "guidance_diffusion_steps": models.guidance_diffusion_steps,
                  "min_goal_distance": models.min_goal_distance}
        sizes: dict[str, dict[str, Any]] = {
            "quick": {"goals": 4, "generated": 32},
            "standard": {"goals": 32, "generated": 128, "shared_evaluator_steps": 500},
            "paper": {"goals": 32, "generated": 256}}
        return cls(**shared, **sizes[scale])

    @property
    def models(self) -> GuidanceModels:
        """The models of this notebook, as the guidance notebooks load them (one cache key)."""
        return GuidanceModels(scale=self.scale, stand_in_clips=self.stand_in_clips,
                              frames=self.frames, train_steps=self.train_steps,
                              batch_size=self.batch_size, diffusion_steps=self.diffusion_steps,
                              guidance_diffusion_steps=self.guidance_diffusion_steps,
                              min_goal_distance=self.min_goal_distance)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def motion_predictions(self) -> tuple[str, ...]:
        """GMD-A4's motion arms this scale trains: both, or x0 alone where the scale does not
        run the ε motion arm (``settings.not_run``: the standard scale's registered cut)."""
        if set(rule_settings.not_run("GMD-A4", self.scale)) >= set(A4_PARTS):
            return ("x0",)
        return tuple(PREDICTIONS)

    @property
    def a4_not_run(self) -> dict[str, str]:
        """GMD-A4's parts this scale does not run, each with why (``settings.not_run``)."""
        return rule_settings.not_run("GMD-A4", self.scale)

    @property
    def longer_eps_run(self) -> bool:
        """Whether GMD-A4's longer ε run (``models.longer_run``, 2× the motion budget; outside
        the rule) is trained: at the paper scale (docs/COMPUTE.md §3d), and in quick runs as a
        test of that code; not at the standard scale."""
        return self.scale != "standard"

    def data(self, data_dir: DataDir = None,
             representation: Representation = "absolute") -> DataConfig:
        """The windows (``data_dir`` or the stand-in set) in ``representation``: absolute
        root by default, the trajectory models' (``GuidanceModels.data``)."""
        return self.models.data(data_dir, representation)

    def motion_data(self, data_dir: DataDir = None) -> DataConfig:
        """GMD-A4's motion windows: :meth:`data` in ``motion_representation``."""
        return self.data(data_dir, self.motion_representation)

    def spec(self, task: Task, prediction: Literal["x0", "epsilon"], data: DataConfig,
             seed: int = 0) -> GMDModelSpec:
        """One of the four models (trajectory/motion × x0/ε), ``GuidanceModels.spec``: x0 and
        ε of a task share the architecture and the training budget. Below the paper scale the
        motion models are text-conditioned, so that A4's x0 model *is* GMD-B3's relative-root
        model (``root_representation.Settings.motion_spec``, one cache key; docs/COMPUTE.md
        §3d) and its ε model the same spec predicting ε; A4 samples both with the null
        condition (``guidance.sample`` without text: the unconditional model that
        classifier-free training keeps). The paper scale keeps today's unconditional models."""
        return self.models.spec(task, prediction, data, seed)

    def guidance_trajectory_spec(self, prediction: Literal["x0", "epsilon"], data: DataConfig,
                                 seed: int = 0) -> GMDModelSpec:
        """The trajectory model of the guidance experiments (GMD-A3 in notebook 01, GMD-F1 in
        06, GMD-B2 in 02: one cache key), ``GuidanceModels.guidance_trajectory_spec``: GMD's
        diffusion, T = ``guidance_diffusion_steps`` (1000) and the ``GUIDANCE_SCHEDULE``."""
        return self.models.guidance_trajectory_spec(prediction, data, seed)

    def evaluator_config(self, data_id: str) -> EvaluatorConfig:
        """The package's evaluator (tiny in quick mode), named after the training windows; at
        the standard scale notebooks 02's and 03's
        (``emphasis_projection.experiment.window_evaluator``: the same relative-root windows, no
        name, so one cache key)."""
        if self.quick:
            return EvaluatorConfig(dim=16, hidden=32, data_id=data_id).replace(steps=30)
        if self.shared_evaluator_steps is not None:
            return EvaluatorConfig().replace(steps=self.shared_evaluator_steps)
        return EvaluatorConfig(data_id=data_id)


def guidance_trajectory_spec(scale: str, prediction: Literal["x0", "epsilon"] = "epsilon",
                             data_dir: DataDir = None, seed: int = 0) -> GMDModelSpec:
    """``Settings.for_scale(scale).guidance_trajectory_spec`` on the scale's windows: the
    trajectory model every guidance experiment shares (GMD's trajectory model predicts ε;
    T = 1000 at the paper scale, 100 at standard)."""
    settings = Settings.for_scale(scale)
    return settings.guidance_trajectory_spec(prediction, settings.data(data_dir), seed)


#: the two parametrisations and the short tags of their measurement names.
PREDICTIONS = {"x0": "x0", "epsilon": "eps"}


#: GMD-A4's registered parts (every one reads the ε motion arm)
A4_PARTS = ("eps_motion_more_jagged", "eps_motion_worse_fid",
            "choice_matters_less_for_trajectories")


#: a figure's path, as ``ClaimResult.figures`` takes it
FigurePath = str | os.PathLike


#: each prediction's role in GMD-A3 and A4 (``core.gates.ROLES``): GMD's trajectory model
#: predicts ε and its motion model x0 (``a4.MOTION_ROLES``), so those are the reference arms
#: the other is compared against (and the only arms the sample gates judge)
TRAJECTORY_ROLES = {"epsilon": "reference", "x0": "treatment"}


def trajectory_reference(test: MotionWindows) -> dict[str, float]:
    """The ``gmd_trajectory`` gates' reference: the test windows' own path length and root
    jerk."""
    return model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())


def trajectory_model_values(model: TrainedGMD, unguided: Any, test: MotionWindows,
                            train: MotionWindows, seed: int) -> dict[str, float]:
    """A trajectory model's ``gmd_trajectory`` gate values: the path length of its unguided
    samples and its held-out x̂0 error over the Gaussian denoiser's."""
    return {**model_gates.trajectory_gate_values(model, unguided),
            **model_gates.denoising_gate_values(model, test, train, seed=seed)}


def window_needs(scale: str) -> WindowNeeds:
    """What notebook 01 cuts from a data folder at ``scale``: windows of ``Settings.frames``
    frames (at least ``windows.DataConfig``'s) every ``DataConfig``'s stride, one per split at
    least (``run.params`` asks this before any kernel starts)."""
    default = DataConfig()
    return WindowNeeds(max(default.frames, Settings.for_scale(scale).frames), default.stride)
