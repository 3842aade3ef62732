"""Notebook 02's settings and what its claims share (GMD appendix B; GMD-B1…B3).

:class:`Settings`: every size and step count of ``notebooks/02_root_representation.ipynb`` at
one scale (B1's clips, B2's trajectory models and targets, B3's motion models and evaluator),
with :data:`B3_PARTS` and whether a scale runs B3 at all (``Settings.runs_b3``);
:func:`settings_markdown`, the table of a run's numbers; :func:`load_or_train_per_representation`,
one model per root representation and seed (B2's trajectory models, B3's motion models);
:data:`REPRESENTATION_ROLES`, each representation's role in B2's and B3's gates.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from repro.core.tables import markdown_table
from repro.gmd import settings as rule_settings
from repro.gmd.guidance import GMD_CFG_SCALE, default_stop_step
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    GUIDANCE_SCHEDULE,
    GUIDANCE_STOP_T,
    MOTION_TRAINING,
    STANDARD_DIFFUSION_STEPS,
    STANDARD_MOTION_TRAINING,
    STANDARD_TRAJECTORY_TRAINING,
    TRAJECTORY_TRAINING,
    X0_CLAMP,
    GMDModelSpec,
    TrainedGMD,
    load_or_train_many,
    training_fields,
)
from repro.gmd.settings import seeds_of
from repro.gmd.windows import (
    REPRESENTATIONS,
    DataConfig,
    DataDir,
    MotionWindows,
)
from repro.infra.context import RunSettings, check_scale
from repro.models.evaluator import EvaluatorConfig
from repro.motion.usability import WindowNeeds

__all__ = ["B3_PARTS", "window_needs", "FigurePath", "QUICK_TRAJECTORY_DIFFUSION_STEPS",
           "REPRESENTATION_ROLES", "Settings", "Windows",
           "load_or_train_per_representation", "settings_markdown"]


#: GMD-B3's registered parts (every one reads the motion models and the evaluator)
B3_PARTS = ("abs_lower_fid", "abs_diversity_closer_to_real", "abs_r_precision_not_worse")


#: the quick scale's T of GMD-B2's trajectory models (notebook 01's quick guidance T): its stop
#: step is t = 1, so rel imputation leaves a free step (a test of the code, never a result)
QUICK_TRAJECTORY_DIFFUSION_STEPS = 50


@dataclass(frozen=True)
class Settings(RunSettings):
    """Every size and step count of notebook 02 at one scale, fixed before any verdict was seen.

    GMD-B2 (paper scale) uses the guidance experiments' trajectory model (:meth:`trajectory_spec`:
    ε prediction, ``TRAJECTORY_ARCHITECTURE``, T = 1000 cosine), sampled with
    GMD's stop step t = 20 and ±6 clamp of x̂0 (``models``); GMD-B3 a text-conditioned
    x0 motion model (GMD's motion model predicts x0; ``MOTION_ARCHITECTURE``),
    both trained to convergence (``models.training_fields``; ``trajectory_steps`` /
    ``motion_steps`` are the step caps), the motion model sampled with
    classifier-free guidance at GMD's scale (``guidance.sample_classifier_free``). ``seeds``
    (B2) and ``motion_seeds`` (B3) come from ``settings.seeds_of``. The standard scale
    (docs/COMPUTE.md §3) trains the standard architectures for a fixed step count, T = 100 for
    every model (the stop step at the same fraction, 2), 3 seeds each and 128 B3 samples —
    for B3 only the numbers its rule quotes: the standard scale runs none of B3's parts
    (:attr:`runs_b3`, a registered cut). Quick mode shrinks everything, T included (a test of
    the code, never a result)."""

    scale: str
    seeds: int
    motion_seeds: int
    stand_in_clips: int
    stride: int
    diffusion_steps: int
    trajectory_steps: int
    motion_steps: int
    sensitivity_clips: int
    targets: int
    evaluation_windows: int
    evaluator_steps: int

    @classmethod
    def for_scale(cls, scale: str) -> Settings:
        check_scale(scale)
        if scale == "quick":
            return cls(scale=scale, seeds=1, motion_seeds=1, stand_in_clips=120, stride=8,
                       diffusion_steps=20, trajectory_steps=20, motion_steps=20,
                       sensitivity_clips=8, targets=8, evaluation_windows=96,
                       evaluator_steps=30)
        if scale == "standard":
            return cls(scale=scale, seeds=seeds_of("GMD-B2", scale),
                       motion_seeds=seeds_of("GMD-B3", scale), stand_in_clips=2000, stride=24,
                       diffusion_steps=STANDARD_DIFFUSION_STEPS,
                       trajectory_steps=STANDARD_TRAJECTORY_TRAINING.step_cap,
                       motion_steps=STANDARD_MOTION_TRAINING.step_cap, sensitivity_clips=64,
                       targets=64, evaluation_windows=128, evaluator_steps=500)
        return cls(scale=scale, seeds=seeds_of("GMD-B2", scale),
                   motion_seeds=seeds_of("GMD-B3", scale), stand_in_clips=2000,
                   stride=24, diffusion_steps=100,
                   trajectory_steps=TRAJECTORY_TRAINING.step_cap,
                   motion_steps=MOTION_TRAINING.step_cap, sensitivity_clips=64, targets=64,
                   evaluation_windows=256, evaluator_steps=500)

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def trajectory_diffusion_steps(self) -> int:
        """T of the B2 trajectory models: GMD's 1000 at the paper scale, ``diffusion_steps`` at
        the standard scale (100), and at the quick scale notebook 01's guidance T
        (``QUICK_TRAJECTORY_DIFFUSION_STEPS``, 50): GMD's stop at 2 % of T is then t = 1, so a
        free step follows imputation (at T = 20 the stop is t = 0, rel imputation sets the
        targets exactly whatever the model, and the A/A null of the imputation part would have
        no between-model spread)."""
        if self.scale == "paper":
            return GUIDANCE_DIFFUSION_STEPS
        if self.scale == "quick":
            return QUICK_TRAJECTORY_DIFFUSION_STEPS
        return self.diffusion_steps

    @property
    def guidance_stop_t(self) -> int:
        """Imputation and guidance act while t ≥ this: GMD's 20 of T = 1000, scaled to a
        quick run's T (``guidance.default_stop_step``)."""
        steps = self.trajectory_diffusion_steps
        if steps == GUIDANCE_DIFFUSION_STEPS:
            return GUIDANCE_STOP_T
        return default_stop_step(steps)

    @property
    def x0_clamp(self) -> float:
        """GMD's clamp of the ε trajectory model's x̂0 (±6, ``X0_CLAMP``)."""
        return X0_CLAMP

    @property
    def b3_not_run(self) -> dict[str, str]:
        """GMD-B3's parts this scale does not run, each with why (``settings.not_run``)."""
        return rule_settings.not_run("GMD-B3", self.scale)

    @property
    def runs_b3(self) -> bool:
        """Whether this scale runs GMD-B3's experiment (its motion models, evaluator, samples,
        gates and controls): not where every part is a registered cut (``settings.not_run``:
        the standard scale), which records the claim with ``b3.b3_not_run_result``."""
        return not set(B3_PARTS) <= set(self.b3_not_run)

    @property
    def b3_control_options(self) -> dict[str, int]:
        """The calibration of GMD-B3's positive control (``b3_controls``'
        keywords): its registered defaults, or in a quick run one calibration draw and one
        round of 8-step bisections (a test of the code)."""
        if self.quick:
            return {"calibration_draws": 1, "rounds": 1, "iterations": 8}
        return {}

    def sampling_parameters(self) -> dict[str, float | int]:
        """What a B2 sidecar records as ``extra.parameters``."""
        return {"num_timesteps": self.trajectory_diffusion_steps,
                "guidance_stop_t": self.guidance_stop_t, "x0_clamp": self.x0_clamp}

    def data(self, representation: str, data_dir: DataDir = None) -> DataConfig:
        """48-frame windows in ``representation`` (one of ``REPRESENTATIONS``)."""
        return DataConfig(data_dir=data_dir, stand_in_clips=self.stand_in_clips,
                          stride=self.stride, representation=representation)

    def evaluator_config(self) -> EvaluatorConfig:
        """The package's evaluator with ``evaluator_steps`` (full mode: its default, 500)."""
        return EvaluatorConfig().replace(steps=self.evaluator_steps)

    def trajectory_spec(self, representation: str, seed: int,
                        data_dir: DataDir = None) -> GMDModelSpec:
        """The guidance experiments' trajectory model: ε prediction, the family's architecture
        and convergence training (``models.training_fields``, ``trajectory_steps`` the cap),
        ``trajectory_diffusion_steps`` of the ``GUIDANCE_SCHEDULE``. At the paper and standard
        scales its absolute-
        root model is notebook 01's and 06's
        (``x0_vs_eps.common.guidance_trajectory_spec``: one cache key, tested)."""
        return GMDModelSpec(task="trajectory", prediction="epsilon",
                            data=self.data(representation, data_dir),
                            diffusion_steps=self.trajectory_diffusion_steps,
                            schedule=GUIDANCE_SCHEDULE,
                            **training_fields("trajectory", scale=self.scale,
                                              step_cap=self.trajectory_steps, seed=seed))

    def motion_spec(self, representation: str, seed: int,
                    data_dir: DataDir = None) -> GMDModelSpec:
        return GMDModelSpec(task="motion", prediction="x0", text_conditioned=True,
                            data=self.data(representation, data_dir),
                            diffusion_steps=self.diffusion_steps,
                            **training_fields("motion", scale=self.scale,
                                              step_cap=self.motion_steps, seed=seed))


def settings_markdown(settings: Settings, *, seeds: Sequence[int],
                      motion_seeds: Sequence[int]) -> str:
    """The table of this run's numbers: B2's sampling, targets and seeds and B3's guidance
    scale, training steps, windows and seeds — or, where the scale does not run GMD-B3
    (``Settings.runs_b3``), one row saying so in place of B3's."""
    sampling = settings.sampling_parameters()
    rows: list[list[Any]] = [
        ["B2 trajectory model T / stop t / x̂0 clamp",
         f"{sampling['num_timesteps']} / {sampling['guidance_stop_t']} / "
         f"±{sampling['x0_clamp']:g}"],
        ["B2 targets per seed", settings.targets]]
    if settings.runs_b3:
        rows += [["B3 classifier-free guidance scale", GMD_CFG_SCALE],
                 ["B3 motion training steps", settings.motion_steps],
                 ["B3 evaluation windows / evaluator steps",
                  f"{settings.evaluation_windows} / {settings.evaluator_steps}"],
                 ["seeds: B2 / B3", f"{len(seeds)} / {len(motion_seeds)}"]]
    else:
        rows += [["B3", f"not run at the {settings.scale} scale (why: GMD-B3 below)"],
                 ["seeds: B2", len(seeds)]]
    return markdown_table(["setting", "value"], rows)


#: each root representation's role in GMD-B2 and B3 (``core.gates.ROLES``): HumanML3D's
#: relative root is what GMD's ablations start from and the absolute root what they compare
#: against it, so the sample gates judge the relative-root models only
REPRESENTATION_ROLES = {"relative": "reference", "absolute": "treatment"}


#: a figure's path, as ``ClaimResult.figures`` takes it
FigurePath = str | os.PathLike


#: windows[representation]["train" | "test"]: the windows of each root representation
Windows = Mapping[str, Mapping[str, MotionWindows]]


def load_or_train_per_representation(spec: Callable[[str, int, DataDir], GMDModelSpec],
                                     seeds: Sequence[int], windows: Windows, *,
                                     data_dir: DataDir, device: str,
                                     ) -> dict[str, dict[int, TrainedGMD]]:
    """The model of ``spec(representation, seed, data_dir)`` for each representation and
    seed (``models.load_or_train_many``: those not yet cached train in parallel processes),
    keyed [representation][seed]; ``windows[representation]["train"]`` are their windows."""
    models = {}
    for rep in REPRESENTATIONS:
        specs = [spec(rep, s, data_dir) for s in seeds]
        trained = load_or_train_many(specs, windows[rep]["train"], device=device)
        models[rep] = dict(zip(seeds, trained, strict=True))
    return models


def window_needs(scale: str) -> WindowNeeds:
    """What notebook 02 cuts from a data folder at ``scale``: ``windows.DataConfig``'s windows,
    and as many test windows as it draws goal targets from (``Settings.targets``:
    ``goal_targets`` draws them without replacement; ``run.params`` asks this before any
    kernel starts)."""
    default = DataConfig()
    return WindowNeeds(default.frames, default.stride,
                       {"train": 1, "test": Settings.for_scale(scale).targets})
