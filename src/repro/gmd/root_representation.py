"""Relative vs absolute root representation (GMD appendix B; claims GMD-B1…B3).

Notation. A clip has T frames of HumanML3D features f_t (relative root, "rel") or of GMD's
absolute-root features g_t = rel→abs(f)_t ("abs"; REFERENCE.md "Absolute root"):

    rel:  f_t[0] = half-angle velocity ω_t,   f_t[1:3] = root x/z velocity v_t (facing frame)
    abs:  g_t[0] = accumulated half-angle a_t, g_t[1:3] = world root x/z p_t

and the global root path is (``features.recover_root``)

    a_t = Σ_{s<t} ω_s,    p_t = Σ_{s<t} R(2·a_{s+1})⁻¹ v_s        (rel; R = rotation about +Y)
    p_t = g_t[1:3]                                               (abs)

So in rel every p_t depends on all earlier ω_s and v_s, non-linearly through R(2a): a change
δω at frame i turns the whole remaining path about p_i by 2δω (a_{i+1} onward change, and
the step i → i+1 is taken in the facing frame of i+1), a change δv at frame i
shifts every later frame by δv. In abs p_t depends on g_t alone.

This module holds the logic of ``notebooks/02_root_representation.ipynb``, on top of the tiny-GMD
modules of ``repro.gmd``: the notebook's fixed settings (:class:`Settings`); the exact round
trip and the sensitivity study (GMD-B1); location imputation and guidance in both
representations (GMD-B2); Table B.1's evaluation (GMD-B3, ``measurements``) run on both,
except at a scale that runs none of B3's parts (``Settings.runs_b3``: the claim is recorded
as not run, with why); each claim's controls, figures, reading and result. Representations
are named as ``motion.humanml3d.REPRESENTATIONS`` ("relative", "absolute"); "rel"/"abs"
(``windows.short_label``) only name measurements.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from repro.claims.result import ClaimResult, Controls
from repro.core import metrics
from repro.core.diffusion import Guidance, Imputation
from repro.core.tables import interval_text, markdown_table, render
from repro.gmd import measurements, model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_readings,
    calibrate_increasing,
    control_seed,
    draw_indices,
    located,
    reference_model,
)
from repro.gmd.figures import count_below, either
from repro.gmd.guidance import (
    GMD_CFG_SCALE,
    GMD_GUIDANCE_STRENGTH,
    default_stop_step,
    sample,
)
from repro.gmd.measurements import (
    EvaluationSet,
    jitter_of,
    table_row,
)
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
    describe,
    load_or_train_many,
    training_fields,
)
from repro.gmd.settings import seeds_of
from repro.gmd.windows import (
    REPRESENTATIONS,
    DataConfig,
    DataDir,
    FeatureSpace,
    MotionWindows,
    short_label,
)
from repro.infra import paths
from repro.infra.context import RunContext, RunSettings, check_scale
from repro.models.evaluator import Evaluator, EvaluatorConfig, load_or_train_evaluator
from repro.motion.features import (
    FEATURE_DIM,
    absolute_features_to_joints,
    absolute_to_relative_root,
    features_to_joints,
    recover_root,
    relative_to_absolute_root,
)
from repro.motion.plotting import save_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["B1Study", "B2_SLOTS", "B2_THRESHOLD", "B3Evaluation", "B3_DEGRADATION", "B3_PARTS",
           "ImputationRun", "LINEARISATION_DELTAS", "LocationTask", "METHODS",
           "QUICK_TRAJECTORY_DIFFUSION_STEPS", "REAL_CLIP", "REGISTERED_METHODS",
           "REPRESENTATION_ROLES", "ROOT_PARAMETERS", "RoundTrip", "SensitivityResult",
           "SensitivitySetup", "Settings", "abs_location_imputation", "b1_figures", "b1_reading",
           "b1_result", "b1_study", "b2_aa_readings", "b2_controls", "b2_model_records",
           "b2_result", "b2_runs", "b2_table_markdown", "b3_controls", "b3_evaluation",
           "b3_model_records", "b3_not_run_markdown", "b3_not_run_result", "b3_result", "b3_rows",
           "facing_path_root", "global_root_xz", "impute_locations", "linearisation_error",
           "load_clips", "load_or_train_per_representation", "location_errors", "location_loss",
           "location_task", "perturbation_displacement", "plot_imputation", "plot_method_errors",
           "plot_representations", "plot_sensitivity", "reading_b1", "reading_b2", "reading_b3",
           "real_clip_file", "registered_measurements", "rel_location_imputation", "root_jacobian",
           "round_trip", "round_trip_markdown", "sensitivity_study", "settings_markdown"]

#: the root entries a perturbation touches: [0] rotation (ω or a), [1:3] linear (v or p).
ROOT_PARAMETERS = slice(0, 3)


# ------------------------------------------------------------------------------- round trip

@dataclass(frozen=True)
class RoundTrip:
    """Errors of the exact conversions on one clip (float64).

    ``rel_abs_rel``: max |abs→rel(rel→abs(f)) − f| over every entry except the last frame's
    dims 0–2 (not determined by abs and never read by ``recover_root``; GMD repeats the
    previous frame's values there). ``abs_rel_abs``: max |rel→abs(abs→rel(g)) − g| over all
    entries. ``joints``: max |features_to_joints(f) − absolute_features_to_joints(g)| (m).
    ``last_frame_velocity``: the (irrelevant) change of the last frame's dims 0–2, for the
    record.
    """

    rel_abs_rel: float
    abs_rel_abs: float
    joints: float
    last_frame_velocity: float
    frames: int

    @property
    def max_error(self) -> float:
        """The registered ``round_trip_max_error``: the larger of the two feature round trips."""
        return max(self.rel_abs_rel, self.abs_rel_abs)


def round_trip(features: np.ndarray) -> RoundTrip:
    """Both round trips of one relative-root clip (T, 263), computed in float64."""
    rel = np.asarray(features, dtype=np.float64)
    absolute = relative_to_absolute_root(rel)
    back = absolute_to_relative_root(absolute)
    determined = np.ones_like(rel, dtype=bool)
    determined[-1, ROOT_PARAMETERS] = False
    again = relative_to_absolute_root(absolute_to_relative_root(absolute))
    joints = np.abs(features_to_joints(rel) - absolute_features_to_joints(absolute)).max()
    return RoundTrip(
        rel_abs_rel=float(np.abs(back - rel)[determined].max()),
        abs_rel_abs=float(np.abs(again - absolute).max()),
        joints=float(joints),
        last_frame_velocity=float(np.abs(back - rel)[-1, ROOT_PARAMETERS].max()),
        frames=int(len(rel)),
    )


# ------------------------------------------------------------------------------ sensitivity

def global_root_xz(features: Tensor, representation: str) -> Tensor:
    """Global root x/z (..., T, 2): accumulated ("relative", ``recover_root``) or read
    ("absolute")."""
    if representation == "relative":
        return recover_root(features)[1][..., [0, 2]]
    if representation == "absolute":
        return features[..., 1:3]
    raise ValueError(f"representation must be one of {REPRESENTATIONS}, got {representation!r}")


def _with_root(features: Tensor, root: Tensor) -> Tensor:
    return torch.cat((root, features[..., 3:]), dim=-1)


def root_jacobian(features: np.ndarray | Tensor, representation: str) -> np.ndarray:
    """J[t, :, s, :] = ∂p_t / ∂(root entries 0:3 of frame s), shape (T, 2, T, 3), float64.

    rel: lower-triangular in (t, s) — p_t depends on every frame s < t; abs: J[t, :, t, 1:3]
    = I and zero elsewhere. Computed with ``torch.autograd.functional.jacobian``.
    """
    x = torch.as_tensor(np.asarray(features), dtype=torch.float64)
    root = x[:, ROOT_PARAMETERS].clone()

    def path(r: Tensor) -> Tensor:
        return global_root_xz(_with_root(x, r), representation)

    return torch.autograd.functional.jacobian(path, root).numpy()


def perturbation_displacement(features: np.ndarray | Tensor, representation: str, frame: int,
                              delta: Sequence[float]) -> np.ndarray:
    """‖p_t(f + δ·e_frame) − p_t(f)‖ for every t (T,), in metres: the exact (not linearised)
    change of the global root path when the root entries 0:3 of ``frame`` change by ``delta``.
    """
    x = torch.as_tensor(np.asarray(features), dtype=torch.float64)
    if not 0 <= frame < x.shape[-2]:
        raise ValueError(f"frame {frame} outside the clip's {x.shape[-2]} frames")
    step = torch.zeros_like(x)
    step[frame, ROOT_PARAMETERS] = torch.as_tensor(np.asarray(delta, dtype=np.float64))
    before = global_root_xz(x, representation)
    after = global_root_xz(x + step, representation)
    return (after - before).norm(dim=-1).numpy()


@dataclass(frozen=True)
class SensitivitySetup:
    """The sensitivity experiment, fixed before it ran (GMD-B1).

    Every clip is cut to its first ``window`` frames; the perturbed frame is ``early_frame``;
    the gap of frame t is t − ``early_frame`` (0 … window − 1 − early_frame; rel moves p_t
    only from gap 1 on, abs only at gap 0); *late frames* are the last ``late_frames`` frames
    of the window. The growth is the mean displacement at the largest gap over that at gap 1
    (the smallest gap at which rel is affected at all). Perturbations: ``delta_rotation`` on
    entry 0 (rel: the half-angle velocity ω, i.e. a heading change of 2·δ; abs: the
    accumulated half-angle a) and ``delta_linear`` on entries 1 and 2 (rel: the x/z velocity
    in m/frame; abs: the world x/z in m). The registered measurement uses all three at once.
    """

    window: int = 60
    early_frame: int = 5
    late_frames: int = 20
    delta_rotation: float = 0.01
    delta_linear: float = 0.01

    def __post_init__(self) -> None:
        if not 0 <= self.early_frame < self.window - self.late_frames:
            raise ValueError("the early frame must come before the late frames")

    @property
    def gaps(self) -> np.ndarray:
        return np.arange(0, self.window - self.early_frame)

    @property
    def late_gaps(self) -> np.ndarray:
        """Gaps of the late frames (frames window − late_frames … window − 1)."""
        first = self.window - self.late_frames - self.early_frame
        return np.arange(first, self.window - self.early_frame)

    def deltas(self) -> dict[str, tuple[float, float, float]]:
        r, v = self.delta_rotation, self.delta_linear
        return {"rotation": (r, 0.0, 0.0), "linear": (0.0, v, v), "both": (r, v, v)}


@dataclass
class SensitivityResult:
    """Displacements (clips, gaps) per representation and perturbation, and the summary."""

    setup: SensitivitySetup
    clip_ids: list[str]
    #: displacement[representation][perturbation]: (clips, gaps) in metres, gap = 0 … .
    displacement: dict[str, dict[str, np.ndarray]]
    #: travelled path length of each clip from the pivot p_i to the window's end (m).
    path_length: np.ndarray

    def late_mean(self, representation: str, perturbation: str = "both") -> float:
        """Mean displacement over clips and late frames (m): ``{rel,abs}_late_displacement``."""
        index = self.setup.late_gaps
        return float(self.displacement[representation][perturbation][:, index].mean())

    def growth(self, representation: str = "relative", perturbation: str = "both") -> float:
        """Mean displacement at the largest gap / at gap 1 (over clips); ``inf`` when nothing
        moves at gap 1 but something does later, ``nan`` when nothing moves at all."""
        curve = self.displacement[representation][perturbation].mean(axis=0)
        if curve[1] > 0:
            return float(curve[-1] / curve[1])
        return float("inf") if curve[-1] > 0 else float("nan")

    def change_size(self, perturbation: str = "both") -> float:
        """The perturbation's own size where it is made (m): abs's displacement at gap 0, the
        mean over clips (``abs_early_displacement``): what a late displacement is measured
        against (not abs's late frames, which are 0 by construction)."""
        return float(self.displacement["absolute"][perturbation][:, 0].mean())

    def measurements(self) -> dict[str, float]:
        """Exactly the names GMD-B1's rule reads (besides ``round_trip_max_error``)."""
        return {"rel_late_displacement": self.late_mean("relative"),
                "abs_late_displacement": self.late_mean("absolute"),
                "abs_early_displacement": self.change_size(),
                "rel_sensitivity_growth": self.growth("relative")}

    def summary(self) -> dict[str, object]:
        """Every curve's mean at the smallest, a middle and the largest gap, and the setup."""
        out: dict[str, object] = {"setup": asdict(self.setup), "clips": len(self.clip_ids)}
        for rep, curves in self.displacement.items():
            for name, values in curves.items():
                mean = values.mean(axis=0)
                middle = len(mean) // 2
                out[f"{short_label(rep)}_{name}"] = {
                    "gap_0": float(mean[0]), "gap_1": float(mean[1]),
                    f"gap_{middle}": float(mean[middle]), f"gap_{len(mean) - 1}": float(mean[-1]),
                    "late_mean": self.late_mean(rep, name)}
        return out


def sensitivity_study(clips: Sequence[np.ndarray], setup: SensitivitySetup,
                      clip_ids: Sequence[str] | None = None) -> SensitivityResult:
    """Perturb the early frame's root entries of every clip (relative features (T ≥ window,
    263)) in both representations and record the exact displacement of every later frame."""
    clips = [np.asarray(c, dtype=np.float64)[: setup.window] for c in clips]
    if not clips or any(len(c) < setup.window for c in clips):
        raise ValueError(f"every clip needs at least {setup.window} frames")
    ids = list(clip_ids) if clip_ids is not None else [str(i) for i in range(len(clips))]
    later = slice(setup.early_frame, setup.window)
    displacement: dict[str, dict[str, np.ndarray]] = {r: {} for r in REPRESENTATIONS}
    for name, delta in setup.deltas().items():
        for rep in REPRESENTATIONS:
            rows = []
            for clip in clips:
                x = clip if rep == "relative" else relative_to_absolute_root(clip)
                rows.append(perturbation_displacement(x, rep, setup.early_frame, delta)[later])
            displacement[rep][name] = np.stack(rows)
    lengths = []
    for clip in clips:
        p = global_root_xz(torch.from_numpy(clip), "relative").numpy()[setup.early_frame:]
        lengths.append(float(np.linalg.norm(np.diff(p, axis=0), axis=-1).sum()))
    return SensitivityResult(setup, ids, displacement, np.asarray(lengths))


def linearisation_error(features: np.ndarray, frame: int, deltas: Sequence[float]) -> np.ndarray:
    """Non-linearity of rel: for each rotation perturbation δ, max_t ‖Δp_t − J·δ‖ / max_t ‖J·δ‖,
    the relative error of the first-order (Jacobian) prediction of the displaced path.
    Zero for abs (linear: p_t = g_t), and for rel's linear velocities (p is linear in v)."""
    x = np.asarray(features, dtype=np.float64)
    jacobian = root_jacobian(x, "relative")[:, :, frame, 0]           # (T, 2)
    errors = []
    for delta in deltas:
        base = global_root_xz(torch.from_numpy(x), "relative").numpy()
        moved = x.copy()
        moved[frame, 0] += delta
        exact = global_root_xz(torch.from_numpy(moved), "relative").numpy() - base
        linear = jacobian * delta
        errors.append(np.linalg.norm(exact - linear, axis=-1).max()
                      / max(np.linalg.norm(linear, axis=-1).max(), 1e-300))
    return np.asarray(errors)


# ------------------------------------------------------------------ the notebook's settings

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
        the standard scale), which records the claim with :func:`b3_not_run_result`."""
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
        root model is notebook 01's and 06's (``x0_vs_eps.guidance_trajectory_spec``: one cache
        key, tested)."""
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


def load_clips(root: Path, split: str, *, min_frames: int, n: int) -> tuple[list[str],
                                                                            list[np.ndarray]]:
    """The first n clips of ``split`` with at least ``min_frames`` frames (relative features,
    unnormalised, as ``MotionDataset`` keeps them)."""
    from repro.motion.humanml3d import MotionDataset

    dataset = MotionDataset(root, split, normalise=False)
    ids, clips = [], []
    for index in range(len(dataset)):
        item = dataset[index]
        if item["length"] >= min_frames:
            ids.append(item["id"])
            clips.append(item["motion"][:item["length"]].numpy())
        if len(clips) == n:
            break
    return ids, clips



# ------------------------------------------------------------------------------------------------
# GMD-B2: asking a trajectory model for locations, like for like in both root representations.
#
# GMD appendix B: "imputing specific values becomes ill-posed [in rel] since there are many
# possible sets of values that are satisfiable. On the other hand, for abs, the imputation and
# optimization of z become straightforward as they only involve replacing or updating z(i)".
# So the comparison is made twice, each mechanism against itself:
#
# * **imputation** — abs: the world x/z entries at the target frames *are* the locations and
#   are replaced (:func:`abs_location_imputation`). rel: no entry holds a location; p_i is a
#   cumulative sum of every earlier frame's heading and velocity, so a replacement has to fix
#   all of them, and one of the many satisfying sets has to be picked
#   (:func:`rel_location_imputation`, the choice and its reason there).
# * **guidance** — the same L1 goal on the root recovered from x̂0, the same strength and stop
#   step, in both (:func:`location_loss`).
#
# Both mechanisms act while t ≥ the stop step: GMD's trajectory model imputes its key
# locations and is guided while t ≥ 20 of T = 1000 (``sample/generate.py``: imputation of the
# key points until ``impute_slack`` = 20, guidance until ``cond_until`` = 20). The free steps
# after it are where a rel sample's small changes compound into its locations (GMD-B1). Part of
# ``notebooks/02_root_representation.ipynb``; the figures are in ``repro.gmd.figures``.
# ------------------------------------------------------------------------------------------------

#: the methods run on every seed: unguided, imputation and guidance in each representation.
METHODS = ("abs_unguided", "abs_imputation", "abs_guidance",
           "rel_unguided", "rel_imputation", "rel_guidance")


#: a method's registered measurement: ``<method>_error`` (the mean location error, m).
REGISTERED_METHODS = ("abs_imputation", "rel_imputation", "abs_guidance", "rel_guidance")


@dataclass(frozen=True)
class LocationTask:
    """Reach a waypoint at ``waypoint_frame`` and a goal at the last frame (GMD-B2).

    ``targets`` (n, 2, 2): for each sample the world x/z at the waypoint and at the goal,
    taken from one test window each (places a motion of the data set does reach in time).
    """

    targets: np.ndarray
    waypoint_frame: int
    goal_frame: int

    @property
    def frames(self) -> tuple[int, int]:
        return (self.waypoint_frame, self.goal_frame)

    @property
    def n(self) -> int:
        return int(self.targets.shape[0])


def location_task(test_windows: MotionWindows, n: int, *, seed: int) -> LocationTask:
    """n waypoint/goal pairs from n test windows drawn with ``seed``: the waypoint frame is
    the middle frame (frames/2 − 1), the goal frame the last."""
    frames = test_windows.frames
    waypoint = frames // 2 - 1
    if n > len(test_windows):
        raise ValueError(f"asked for {n} targets from {len(test_windows)} windows")
    picks = np.random.default_rng(seed).choice(len(test_windows), n, replace=False)
    space = test_windows.space("trajectory")
    with torch.no_grad():
        path = space.root_xz(test_windows.trajectory()[torch.from_numpy(picks)]).numpy()
    targets = path[:, [waypoint, frames - 1]]
    return LocationTask(targets.astype(np.float32), waypoint, frames - 1)


def location_loss(space: FeatureSpace, task: LocationTask) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = Σ_{i ∈ {waypoint, goal}} ‖p_xz(i) − target_i‖₁ (m) per sample: GMD's L1 goal
    function on the un-normalised root of x̂0, summed over the two target frames."""
    frames = list(task.frames)

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)[:, frames]                       # (B, 2, 2)
        target = torch.as_tensor(task.targets, dtype=position.dtype, device=position.device)
        return (position - target).abs().sum(dim=(1, 2))

    return goal


def location_errors(space: FeatureSpace, x: Tensor, task: LocationTask) -> np.ndarray:
    """Euclidean distance (m) of the root x/z to each target, (n, 2): waypoint, goal."""
    with torch.no_grad():
        position = space.root_xz(x.detach())[:, list(task.frames)].cpu().numpy()
    return np.linalg.norm(position - task.targets, axis=-1)


def _normalised(space: FeatureSpace, channel: int, values: np.ndarray) -> np.ndarray:
    return (values - space.mean[channel]) / space.std[channel]


def abs_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """abs: the root x/z entries (channels 1, 2) at the two target frames *are* the targets —
    replace them (GMD's ε-model imputation: x_{t−1} ← q_sample(target, t−1) on the mask, the
    target itself at t = 0); nothing else is touched."""
    if space.representation != "absolute":
        raise ValueError("abs_location_imputation needs an absolute-root model")
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    target = torch.zeros(task.n, space.channels, frames)
    for k, frame in enumerate(task.frames):
        mask[0, 1:3, frame] = True
        for c in (1, 2):
            target[:, c, frame] = torch.from_numpy(
                _normalised(space, c, task.targets[:, k, c - 1]).astype(np.float32))
    return Imputation(mask, target)


def _facing_half_angle(direction: np.ndarray) -> np.ndarray:
    """The heading half-angle a whose facing frame walks forward (+Z local) along the world
    x/z ``direction`` (..., 2): ``recover_root`` moves a local step (0, 0, v) by R(2a)⁻¹,
    i.e. to (−sin 2a, cos 2a)·v, so 2a = atan2(−d_x, d_z)."""
    return 0.5 * np.arctan2(-direction[..., 0], direction[..., 1])


def facing_path_root(task: LocationTask, frames: int) -> np.ndarray:
    """The rel root entries (n, frames, 3) — half-angle velocity ω and facing-frame x/z
    velocity v — of walking from the origin straight to the waypoint and on to the goal at a
    constant speed per leg, facing the direction of travel (a turn at the first step and at
    the waypoint). Built as an abs path (heading a_t, world p_t) and differenced with
    ``absolute_to_relative_root``, so ``recover_root`` reproduces p_t exactly; the last
    frame's entries repeat the previous frame's (never read)."""
    i, last = task.frames
    waypoint, goal = task.targets[:, 0].astype(np.float64), task.targets[:, 1].astype(np.float64)
    t = np.arange(frames, dtype=np.float64)[None, :, None]
    first_leg = waypoint[:, None, :] * np.minimum(t / i, 1.0)
    second_leg = (goal - waypoint)[:, None, :] * np.clip((t - i) / (last - i), 0.0, 1.0)
    position = first_leg + second_leg                                       # (n, frames, 2)
    heading_first = _facing_half_angle(waypoint)
    # the turn at the waypoint takes the shorter way round (2a unwrapped to within ±π)
    turn = np.angle(np.exp(2j * (_facing_half_angle(goal - waypoint) - heading_first))) / 2
    heading = np.zeros((task.n, frames))
    heading[:, 1:i + 1] = heading_first[:, None]
    heading[:, i + 1:] = (heading_first + turn)[:, None]
    absolute = np.zeros((task.n, frames, FEATURE_DIM))
    absolute[..., 0] = heading
    absolute[..., 1:3] = position
    return np.asarray(absolute_to_relative_root(absolute))[..., :3]


def rel_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """rel: no entry holds p_i, which depends on ω_s and v_s of every s < i, so an imputation
    that guarantees both locations must fix channels 0–2 of *every* frame (only the root
    height, channel 3, is left to the model) — GMD's code imputes a rel (MDM) model the same
    way, overwriting the root rotation and x/z velocity of all frames with those of a whole
    given trajectory. Two locations leave infinitely many such trajectories; we impute
    :func:`facing_path_root` (straight legs, facing the direction of travel), the one that
    asks nothing the locations do not imply and walks forward as the data do."""
    if space.representation != "relative":
        raise ValueError("rel_location_imputation needs a relative-root model")
    root = facing_path_root(task, frames)
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    mask[0, 0:3, :] = True
    target = torch.zeros(task.n, space.channels, frames)
    for c in range(3):
        target[:, c, :] = torch.from_numpy(_normalised(space, c, root[..., c]).astype(np.float32))
    return Imputation(mask, target)


@dataclass
class ImputationRun:
    """One method on one model: the samples (model space) and what was measured."""

    method: str
    samples: Tensor
    location_error: np.ndarray        # (n, 2) m: waypoint, goal
    root_acceleration: float          # m/s², mean over frames (jitter_of, root)
    path_change: float                # m, mean ‖p_t − p_t(unguided, same seed)‖ over all t
    path_change_off_target: float     # m, the same over frames ≥ 3 away from both targets

    @property
    def mean_error(self) -> float:
        return float(self.location_error.mean())

    def summary(self) -> dict[str, float]:
        return {"location_error": self.mean_error,
                "waypoint_error": float(self.location_error[:, 0].mean()),
                "goal_error": float(self.location_error[:, 1].mean()),
                "root_acceleration": self.root_acceleration, "path_change": self.path_change,
                "path_change_off_target": self.path_change_off_target}


def impute_locations(models: Mapping[str, TrainedGMD], task: LocationTask, *, seed: int,
                     stop_t: int, clip_x0: float | None,
                     strength: float = GMD_GUIDANCE_STRENGTH,
                     representations: Sequence[str] = REPRESENTATIONS,
                     ) -> dict[str, ImputationRun]:
    """Every method of :data:`METHODS` from the same seed (same x_T and per-step noise);
    imputation and guidance act while t ≥ ``stop_t`` (GMD: 20 of 1000), an ε model's x̂0 is
    clamped to ±``clip_x0`` (GMD: 6).

    ``models``: {"absolute": absolute-root trajectory model, "relative": relative-root one};
    a method's name starts with the short label of its model's representation;
    ``representations``: those whose methods run (both by default; an A/A control runs the
    reference arm's alone).
    *_imputation: :func:`abs_location_imputation` / :func:`rel_location_imputation`;
    *_guidance: :func:`location_loss` with strength s (GMD: 100).
    """
    runs: dict[str, ImputationRun] = {}
    for rep, label, imputation in (("absolute", "abs", abs_location_imputation),
                                   ("relative", "rel", rel_location_imputation)):
        if rep not in representations:
            continue
        trained = models[rep]
        frames = trained.spec.data.frames
        hooks = {f"{label}_unguided": {},
                 f"{label}_imputation": {"imputation": imputation(trained.space, task, frames)},
                 f"{label}_guidance": {"guidance": Guidance(location_loss(trained.space, task),
                                                            strength=strength)}}
        unguided_path = None
        for method, hook in hooks.items():
            x = sample(trained, task.n, seed=seed, stop_guidance_at=stop_t, clip_x0=clip_x0,
                       **hook)
            with torch.no_grad():
                path = trained.space.root_xz(x).cpu().numpy()
            if unguided_path is None:
                unguided_path = path
            change = np.linalg.norm(path - unguided_path, axis=-1)          # (n, T)
            away = np.ones(frames, dtype=bool)
            for frame in task.frames:
                away[max(frame - 2, 0):frame + 3] = False
            runs[method] = ImputationRun(
                method, x.cpu(), location_errors(trained.space, x, task),
                float(jitter_of(trained, x, part="root").acceleration),
                float(change.mean()), float(change[:, away].mean()))
    return runs


def registered_measurements(runs: dict[int, dict[str, ImputationRun]]) -> dict[str, list[float]]:
    """GMD-B2's measured values: per seed (in ``runs``' order) the mean location error (m) of
    each registered method, named ``<method>_error``, and the two names the rule also reads."""
    measured = {f"{method}_error": [per_seed[method].mean_error for per_seed in runs.values()]
                for method in REGISTERED_METHODS}
    # rel guidance vs abs imputation, under the two names the registered rule reads
    measured["rel_location_error"] = measured["rel_guidance_error"]
    measured["abs_location_error"] = measured["abs_imputation_error"]
    return measured



# ------------------------------------------------------------------------------------------------
# GMD-B3's controls (Table B.1, notebook 02), beside ``repro.gmd.controls``: the evaluation
# windows themselves, degraded by a fixed recipe with the same noise in both arms of a seed, stand
# in for both models' samples; the positive control degrades the abs arm less, by sizes measured
# on calibration draws to plant the FID and diversity-gap effects at their registered δ.
# ------------------------------------------------------------------------------------------------

#: the rel arm's degradation, fixed before any control ran: shrink toward the mean window by
#: 30 %, a shift of 0.25 std along a fixed direction, white noise of 0.1 std (one draw per seed,
#: the same in both arms)
B3_DEGRADATION = {"shrink": 0.3, "shift": 0.25, "noise": 0.1}


#: Table B.1's effects at the registered δ: half the paper's FID drop and gap shrink
B3_FID_RATIO, B3_GAP_RATIO = 1 - 0.1525, 1 - 0.412


#: the diversity pairs of ``evaluator.evaluate_generated`` (its default)
DIVERSITY_PAIRS = 300


def _degraded(features: np.ndarray, *, shrink: float, shift: float, noise: float,
              direction: np.ndarray, seed: int) -> np.ndarray:
    """Relative-root features (n, T, 263) pulled toward their mean window by ``shrink``,
    shifted by ``shift`` per-feature std along ``direction`` and given white noise of
    ``noise`` std (a draw of ``seed``)."""
    mean = features.mean(axis=0, keepdims=True)
    std = features.reshape(-1, features.shape[-1]).std(axis=0) + 1e-6
    white = np.random.default_rng(seed).standard_normal(features.shape)
    out = mean + (1 - shrink) * (features - mean) + std * (shift * direction + noise * white)
    return out.astype(np.float32)


def b3_controls(evaluator: Evaluator, evaluation: EvaluationSet, real_row: Mapping[str, float],
                seeds: Sequence[int], *, calibration_draws: int = 3, rounds: int = 4,
                iterations: int = 12, fid_ratio: float = B3_FID_RATIO,
                gap_ratio: float = B3_GAP_RATIO) -> Controls:
    """GMD-B3's controls: the evaluation windows themselves, degraded (:func:`_degraded`),
    stand in for both models' samples, measured with the experiment's ``measurements.table_row``
    and ``measurements.registered_measurements`` (FID, R@3, Diversity against the same
    evaluation set).

    Paired as the experiment (``b3_rows``: both representations generate for the same
    evaluation captions from the same seed, x_T included, and are scored with the same seed):
    in a seed both arms degrade the same windows with the same white-noise draw
    (:func:`control_seed` with arm 0; another draw per seed) and are scored with the seed.
    Null: both arms degraded by :data:`B3_DEGRADATION` (identical arms: every log ratio 0).
    Positive: the abs arm degraded less — the shrink and shift that, measured on
    ``calibration_draws`` noise draws disjoint from the control's (alternating bisections,
    ``rounds`` times), give FID × (1 − 0.1525) and a diversity gap to real × (1 − 0.412) of
    the rel arm's: part 1's and part 2's δ (no exact transformation moves an FID by a set
    ratio; R@3 is left to come out as it does). Each bisection takes ``iterations`` steps
    (quick runs pass fewer draws, rounds and steps: a test of the code)."""
    features, lengths = evaluation.features, evaluation.lengths
    direction = np.random.default_rng(control_seed(0, 0, stream=40)).standard_normal(
        features.shape[-1])
    direction /= np.linalg.norm(direction)
    real = float(real_row["diversity"])

    truth = evaluator.embed_motions(features, lengths)
    pairs = min(DIVERSITY_PAIRS, len(features))

    def fid_and_gap(shrink: float, shift: float) -> tuple[float, float]:
        """Mean FID and |Diversity − real| over the calibration draws, computed as
        ``evaluate_generated`` computes them."""
        fids, gaps = [], []
        for k in range(calibration_draws):
            generated = evaluator.embed_motions(_degraded(
                features, shrink=shrink, shift=shift, noise=B3_DEGRADATION["noise"],
                direction=direction, seed=control_seed(k, 0, stream=41)), lengths)
            fids.append(metrics.fid(generated, truth))
            gaps.append(abs(metrics.diversity(generated, pairs, k) - real))
        return float(np.mean(fids)), float(np.mean(gaps))

    fid_rel, gap_rel = fid_and_gap(B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"])
    shrink, shift = B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"]
    for _ in range(rounds):
        shrink = calibrate_increasing(lambda b, a=shift: fid_and_gap(b, a)[1],
                                      gap_ratio * gap_rel, high=1.0,
                                      iterations=iterations)
        shift = calibrate_increasing(lambda a, b=shrink: fid_and_gap(b, a)[0],
                                     fid_ratio * fid_rel, high=1.0,
                                     iterations=iterations)
    reached = fid_and_gap(shrink, shift)
    rows: dict[str, dict[str, list[dict[str, float]]]] = {
        "null": {"relative": [], "absolute": []}, "positive": {"relative": [], "absolute": []}}
    for s in seeds:
        def arm(b: float, a: float, s: int = s) -> dict[str, float]:
            generated = _degraded(features, shrink=b, shift=a, noise=B3_DEGRADATION["noise"],
                                  direction=direction, seed=control_seed(s, 0, stream=42))
            return table_row(evaluator, generated, evaluation, seed=s)

        rel = arm(B3_DEGRADATION["shrink"], B3_DEGRADATION["shift"])
        rows["null"]["relative"].append(rel)
        rows["positive"]["relative"].append(rel)
        rows["null"]["absolute"].append(dict(rel))
        rows["positive"]["absolute"].append(arm(shrink, shift))
    return Controls(
        null=measurements.registered_measurements(dict(real_row), rows["null"]),
        positive=measurements.registered_measurements(dict(real_row), rows["positive"]),
        planted={"rel_degradation": B3_DEGRADATION, "abs_shrink": shrink, "abs_shift": shift,
                 "calibrated_fid_ratio": reached[0] / fid_rel,
                 "calibrated_gap_ratio": reached[1] / gap_rel,
                 "calibration_draws": calibration_draws},
        null_text=(f"paired as the experiment: the same {len(features)} evaluation windows "
                   f"with the same noise draw in both arms of a seed (another draw per seed), "
                   f"{len(seeds)} seed(s); no plant: both degraded alike (shrink "
                   f"{B3_DEGRADATION['shrink']:g}, shift {B3_DEGRADATION['shift']:g} std, noise "
                   f"{B3_DEGRADATION['noise']:g} std), identical arms"),
        positive_text=(f"the same paired draws; the abs arm degraded less (shrink "
                       f"{shrink:.3g}, shift {shift:.3g}: FID × {reached[0] / fid_rel:.3g}, "
                       f"diversity gap × {reached[1] / gap_rel:.3g} on {calibration_draws} "
                       f"calibration draws disjoint from the control's)"))



# --- GMD-B2: constructed samples with known location errors -------------------------------

#: E‖d‖ of d ~ N(0, σ²I₂) is σ·√(π/2): the σ that gives a mean location error r̄ is r̄/√(π/2)
_RAYLEIGH_MEAN = float(np.sqrt(np.pi / 2))


def b2_controls(test: MotionWindows, tasks: Mapping[int, Any], seeds: Sequence[int], *,
                mean_error: float = 0.1, abs_factor: float = 0.9) -> Controls:
    """GMD-B2's controls: constructed samples whose location errors are known, measured with
    the experiment's ``location_errors`` (mean over samples and the two target frames). A
    seed's sample set is a draw of test trajectories (as many as the seed's task has targets)
    with the root at the waypoint and goal frames placed at the target plus a Gaussian offset
    d ~ N(0, σ²I₂), σ = ``mean_error``/√(π/2), so E‖d‖ = ``mean_error``.

    Paired as the experiment (``impute_locations``: the four methods — imputation and
    guidance in each representation, ``REGISTERED_METHODS`` — sample the seed's task from the
    same x_T and per-step noise): one draw of trajectories and offsets per seed
    (:func:`control_seed` with arm 0; another draw per seed) is all four arms, toward the
    seed's targets. Null: every arm that draw (equal arms: log(rel / abs) = 0 in every seed).
    Positive: both abs arms' offsets × 0.9, so abs error = 0.9 × rel error exactly and
    log(rel / abs) = −log 0.9, the δ of both ratio parts, in every seed. The threshold part
    (0.1 m − abs imputation error, δ 1 cm) compares one arm with a constant: nothing pairs
    it, and it keeps the draw's own noise — the null's abs error is 0.1 m and the positive's
    0.09 m in expectation only. Tests plant larger effects through ``abs_factor``. The rule's
    two further names are filled as the experiment fills them (rel guidance, abs
    imputation)."""
    space = test.space("trajectory")
    sigma = mean_error / _RAYLEIGH_MEAN
    null: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    positive: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    for s in seeds:
        task = tasks[s]
        frames = list(task.frames)
        x = test.trajectory()[draw_indices(test, task.n, control_seed(s, 0, stream=20))]
        offsets = sigma * np.random.default_rng(control_seed(s, 0, stream=21)).standard_normal(
            (task.n, len(frames), 2))
        for out, factor in ((null, 1.0), (positive, abs_factor)):
            for method in REGISTERED_METHODS:
                scale = factor if method.startswith("abs") else 1.0
                placed = located(space, x, frames, task.targets, scale * offsets)
                out[f"{method}_error"].append(float(location_errors(space, placed, task).mean()))
    for out in (null, positive):
        out["rel_location_error"] = out["rel_guidance_error"]
        out["abs_location_error"] = out["abs_imputation_error"]
    return Controls(null=null, positive=positive,
                    planted={"mean_location_error_m": mean_error, "abs_offset_factor": abs_factor},
                    null_text=(f"paired as the experiment: the same test trajectories, targets "
                               f"and Gaussian offsets (mean length {mean_error:g} m) in all four "
                               f"arms of a seed (another draw per seed), {len(seeds)} seed(s); "
                               f"no plant (equal arms; abs imputation at the 10 cm threshold in "
                               f"expectation, with its draw's own noise)"),
                    positive_text=(f"the same paired draws; both abs arms' offsets × "
                                   f"{abs_factor:g} (abs error {abs_factor:g} × rel's exactly; "
                                   f"mean {abs_factor * mean_error:.3g} m in expectation)"))



# --- notebook 02's reading paragraphs ------------------------------------------------------------

def reading_b1(*, round_trip_error: float, joints_error: float, summary: dict,
               late_gap: int, growth: float, real_growth: float | None,
               linearisation: Sequence[float], deltas: Sequence[float]) -> str:
    """GMD-B1: round trip, the flat linear-velocity curve, the growing rotation curve, the
    first-order error. ``summary`` is ``SensitivityResult.summary()``."""
    linear, rotation = summary["rel_linear"], summary["rel_rotation"]
    last = f"gap_{late_gap}"
    real = ("" if real_growth is None else
            render(" (the real walking clip ×{g:.2f})", g=real_growth))
    errors = ", ".join(render("{e:.1%} at δω = {d:g}", e=e, d=d)
                       for e, d in zip(linearisation, deltas, strict=True))
    flat = abs(linear[last] - linear["gap_1"]) <= 1e-9 * max(linear["gap_1"], 1e-12)
    return render(
        "**Reading** (this run). The round trip is exact to {trip:.1e} over every clip, and "
        "both representations give the same joints to {joints:.1e} m. A linear-velocity "
        "change at the perturbed frame moves the later frames by {lin1:.4f} m at gap 1 and "
        "{linL:.4f} m at gap {gap} ({flat}): p_t depends on *all* earlier steps, but "
        "linearly. A rotation change turns the rest of the path about the perturbed frame's "
        "position: its displacement goes from {rot1:.4f} m at gap 1 to {rotL:.4f} m at gap "
        "{gap}. With all three entries perturbed the displacement grows ×{growth:.2f} from "
        "gap 1 to gap {gap} on the stand-in mean{real}. The Jacobian maps show the structure "
        "(exact, whatever the clip): rel is lower-triangular, every frame depending on all "
        "earlier ones; abs is the identity on the diagonal. The first-order (Jacobian) prediction "
        "of a rotation change is off by {errors}, relatively. On a clip that stands still "
        "the rotation term vanishes: compounding needs travel.",
        trip=round_trip_error, joints=joints_error, lin1=linear["gap_1"], linL=linear[last],
        gap=late_gap, flat=either(flat, "the same shift", "not constant"),
        rot1=rotation["gap_1"], rotL=rotation[last], growth=growth, real=real, errors=errors)


def reading_b2(per_method: dict[str, list[dict[str, float]]], *, seeds: Sequence[int],
               stop_t: int) -> str:
    """GMD-B2: imputation against imputation, guidance against guidance, and what each route
    costs. ``per_method[method]``: ``ImputationRun.summary()`` per seed; ``stop_t``: the step
    after which neither mechanism acts."""
    def values(method: str, key: str = "location_error") -> list[float]:
        return [row[key] for row in per_method[method]]

    def mean(method: str, key: str = "location_error") -> float:
        return float(np.mean(values(method, key)))

    imputation_better = count_below(values("abs_imputation"), values("rel_imputation"))
    guidance_better = count_below(values("abs_guidance"), values("rel_guidance"))
    abs_guidance_helps = mean("abs_guidance") < mean("abs_unguided")
    rel_guidance_helps = mean("rel_guidance") < mean("rel_unguided")
    return render(
        "**Reading** (this run, seeds {seeds}). *Imputation against imputation:* replacing "
        "the two x/z entries in abs ends {abs_imp} m from the targets, replacing the root "
        "entries of every frame in rel {rel_imp} m (abs closer on {ki} of {n} seeds). "
        "{free} The rel imputation dictates the whole root path (every frame's entries are "
        "replaced); against the unguided samples of the same noise it moves the path "
        "{rel_off:.3f} m on frames away from the targets, abs imputation {abs_off:.3f} m. "
        "*Guidance against "
        "guidance:* abs ends {abs_g} m, rel {rel_g} m from the targets (abs closer on {kg} of "
        "{n} seeds); against the unguided samples guidance {abs_help} in abs ({abs_u} m "
        "unguided) and {rel_help} in rel ({rel_u} m).",
        seeds=list(seeds), abs_imp=interval_text(values("abs_imputation")),
        rel_imp=interval_text(values("rel_imputation")), ki=imputation_better, n=len(seeds),
        free=either(stop_t > 0, render(
            "Both replacements hold the targets while t ≥ {stop}; what the last {stop} free "
            "steps move in rel is summed over every earlier frame, in abs it is the entry "
            "itself.", stop=stop_t), "Both replacements act to the last step (t = 0), so both "
            "end on their targets up to rounding."),
        rel_off=mean("rel_imputation", "path_change_off_target"),
        abs_off=mean("abs_imputation", "path_change_off_target"),
        abs_g=interval_text(values("abs_guidance")), rel_g=interval_text(values("rel_guidance")),
        kg=guidance_better, abs_help=either(abs_guidance_helps, "helped", "did not help"),
        rel_help=either(rel_guidance_helps, "helped", "did not help"),
        abs_u=interval_text(values("abs_unguided")), rel_u=interval_text(values("rel_unguided")))


def reading_b3(rows: dict[str, list[dict[str, float]]], real: dict[str, float], *,
               paper_fid: tuple[float, float]) -> str:
    """GMD-B3: each Table B.1 column per representation, concept recall, the distance from
    the real windows. ``rows`` keyed "relative"/"absolute" (``measurements.table_row`` per seed);
    ``paper_fid`` the paper's (rel, abs) FID."""
    def values(rep: str, metric: str) -> list[float]:
        return [row[metric] for row in rows[rep]]

    def lower(metric: str) -> str:
        rel, ab = np.mean(values("relative", metric)), np.mean(values("absolute", metric))
        return "tie" if rel == ab else ("rel" if rel < ab else "abs")

    recall_abs_lower = count_below(values("absolute", "concept_recall"),
                                   values("relative", "concept_recall"))
    n = len(rows["relative"])
    gap_rel = [abs(v - real["diversity"]) for v in values("relative", "diversity")]
    gap_abs = [abs(v - real["diversity"]) for v in values("absolute", "diversity")]
    columns = render(
        "**Reading** (this run, {n} seed(s)). FID: rel {fid_rel} vs abs {fid_abs} (lower "
        "mean: {fid_low}; the paper has abs lower). R-precision top-3: rel {r3_rel} vs abs "
        "{r3_abs}. Diversity gap to the real windows' {div_real:.3f}: rel {gap_rel} vs abs "
        "{gap_abs}.",
        n=n, fid_rel=interval_text(values("relative", "fid")),
        fid_abs=interval_text(values("absolute", "fid")), fid_low=lower("fid"),
        r3_rel=interval_text(values("relative", "r_precision_top3")),
        r3_abs=interval_text(values("absolute", "r_precision_top3")),
        div_real=real["diversity"], gap_rel=interval_text(gap_rel),
        gap_abs=interval_text(gap_abs))
    if not measurements.measurable(values("relative", "concept_recall")
                                   + values("absolute", "concept_recall")):
        return columns + render(
            " Concept recall: {not_measurable} (the folder has no `labels/` for the concept "
            "oracles to compare with). The real windows' R-precision: {r3_real:.2f}.",
            not_measurable=measurements.NOT_MEASURABLE, r3_real=real["r_precision_top3"])
    return columns + render(
        " The concept oracles find fewer of the captioned concepts in abs samples than in rel "
        "samples on {k} of {n} seeds (recall rel {cr_rel} vs abs {cr_abs}). Both tiny models "
        "are far from the real windows (R-precision {r3_real:.2f}, concept recall "
        "{cr_real:.2f}), so this is a weak test of a small effect: the paper's FID difference "
        "({p_rel:g} vs {p_abs:g}) is {share:.0%} of its rel value.",
        n=n, k=recall_abs_lower,
        cr_rel=interval_text(values("relative", "concept_recall")),
        cr_abs=interval_text(values("absolute", "concept_recall")),
        r3_real=real["r_precision_top3"], cr_real=real["concept_recall"],
        p_rel=paper_fid[0], p_abs=paper_fid[1],
        share=(paper_fid[0] - paper_fid[1]) / paper_fid[0])



# --- figures of GMD-B1 and B2 --------------------------------------------------------------------

def plot_representations(clip: np.ndarray, setup: SensitivitySetup, title: str) -> Figure:
    """One clip in both representations (root channels over time) and its top-down path
    after the early-frame perturbation of :class:`SensitivitySetup`, rel vs abs."""
    import matplotlib.pyplot as plt

    rel = np.asarray(clip, dtype=np.float64)[: setup.window]
    absolute = relative_to_absolute_root(rel)
    frames = np.arange(len(rel))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    axes[0].plot(frames, rel[:, 0], label="ω (half-angle/frame)")
    axes[0].plot(frames, rel[:, 1], label="v_x (m/frame)")
    axes[0].plot(frames, rel[:, 2], label="v_z (m/frame)")
    axes[0].set_title("rel: root entries 0–2", fontsize=9)
    axes[1].plot(frames, absolute[:, 0], label="a (half-angle)")
    axes[1].plot(frames, absolute[:, 1], label="x (m)")
    axes[1].plot(frames, absolute[:, 2], label="z (m)")
    axes[1].set_title("abs: root entries 0–2", fontsize=9)
    for ax in axes[:2]:
        ax.axvline(setup.early_frame, color="grey", ls=":", lw=1)
        ax.set_xlabel("frame")
        ax.legend(fontsize=7)
    delta = np.asarray(setup.deltas()["both"])
    path = global_root_xz(torch.from_numpy(rel), "relative").numpy()
    moved_rel = rel.copy()
    moved_rel[setup.early_frame, ROOT_PARAMETERS] += delta
    moved_abs = absolute.copy()
    moved_abs[setup.early_frame, ROOT_PARAMETERS] += delta
    path_rel = global_root_xz(torch.from_numpy(moved_rel), "relative").numpy()
    path_abs = global_root_xz(torch.from_numpy(moved_abs), "absolute").numpy()
    ax = axes[2]
    ax.plot(path[:, 0], path[:, 1], "k-", lw=2, label="original")
    ax.plot(path_rel[:, 0], path_rel[:, 1], "-", color="tab:red", label="perturbed, rel")
    ax.plot(path_abs[:, 0], path_abs[:, 1], "--", color="tab:blue", label="perturbed, abs")
    ax.plot(*path[setup.early_frame], "o", color="grey", ms=5, label=f"frame {setup.early_frame}")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7)
    ax.set_title("top-down root path", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_sensitivity(result: SensitivityResult, clip: np.ndarray,
                     real: SensitivityResult | None = None) -> Figure:
    """(a) mean displacement against the frame gap, rel (rotation, linear, both) and abs;
    (b, c) ‖∂p_t/∂(root entries of frame s)‖_F for one clip, rel and abs."""
    import matplotlib.pyplot as plt

    setup = result.setup
    gaps = setup.gaps
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    ax = axes[0]
    styles = {"rotation": ("tab:orange", "-"), "linear": ("tab:green", "-"),
              "both": ("tab:red", "-")}
    for name, (colour, style) in styles.items():
        ax.plot(gaps, result.displacement["relative"][name].mean(axis=0), style, color=colour,
                label=f"rel, {name}")
    ax.plot(gaps, result.displacement["absolute"]["both"].mean(axis=0), "o--", color="tab:blue",
            ms=3, label="abs, both")
    if real is not None:
        ax.plot(gaps, real.displacement["relative"]["both"][0], ":", color="black",
                label="rel, both (real clip 012314)")
    ax.axvspan(setup.late_gaps[0], setup.late_gaps[-1], color="grey", alpha=0.15,
               label="late frames")
    ax.set_xlabel(f"frame gap t − {setup.early_frame}")
    ax.set_ylabel("root displacement (m)")
    ax.set_title(f"δω = {setup.delta_rotation}, δv = {setup.delta_linear} at frame "
                 f"{setup.early_frame} (mean of {len(result.clip_ids)} clips)", fontsize=9)
    ax.legend(fontsize=7)
    rel = np.asarray(clip, dtype=np.float64)[: setup.window]
    for ax, rep, x in ((axes[1], "relative", rel),
                       (axes[2], "absolute", relative_to_absolute_root(rel))):
        jacobian = np.linalg.norm(root_jacobian(x, rep), axis=(1, 3))
        image = ax.imshow(jacobian, origin="lower", cmap="magma", aspect="auto")
        fig.colorbar(image, ax=ax, fraction=0.046)
        ax.set_xlabel("perturbed frame s")
        ax.set_ylabel("position frame t")
        ax.grid(False)
        ax.set_title(f"{short_label(rep)}: ‖∂p_t / ∂(entries 0–2 of frame s)‖_F", fontsize=9)
    fig.tight_layout()
    return fig


def plot_imputation(models: dict[str, TrainedGMD], runs: dict[str, ImputationRun],
                    task: LocationTask, samples: int = 4) -> Figure:
    """Top-down root paths of a few samples of every method, the targets marked."""
    import matplotlib.pyplot as plt

    by_short_label = {short_label(rep): rep for rep in models}
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, method in zip(axes.ravel(), METHODS, strict=True):
        trained = models[by_short_label[method.split("_")[0]]]
        with torch.no_grad():
            paths = trained.space.root_xz(runs[method].samples[:samples]).numpy()
        for k, path in enumerate(paths):
            colour = colours[k % len(colours)]
            ax.plot(path[:, 0], path[:, 1], "-", color=colour, lw=1.3)
            ax.plot(*path[task.waypoint_frame], "o", color=colour, ms=4)
            ax.plot(*path[-1], ">", color=colour, ms=5)
            for target, marker in zip(task.targets[k], ("x", "*"), strict=True):
                ax.plot(*target, marker, color=colour, ms=10, mew=2)
        error = runs[method].mean_error
        ax.set_title(f"{method.replace('_', ' ')}: error {error:.3f} m", fontsize=9)
        ax.set_aspect("equal", adjustable="datalim")
    for ax in axes[-1]:
        ax.set_xlabel("x (m)")
    for ax in axes[:, 0]:
        ax.set_ylabel("z (m)")
    fig.suptitle(f"waypoint (×, frame {task.waypoint_frame}) and goal (*, last frame); "
                 "dots/arrows: where the samples are at those frames", fontsize=10)
    fig.tight_layout()
    return fig


def plot_method_errors(per_seed: dict[str, list[float]], ylabel: str, title: str) -> Figure:
    """Per-method bars (mean over seeds) with every seed's value as a dot."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6))
    names = list(per_seed)
    for i, name in enumerate(names):
        values = np.asarray(per_seed[name])
        ax.bar(i, values.mean(), color="tab:blue" if name.startswith("abs") else "tab:red",
               alpha=0.6)
        ax.plot(np.full(len(values), i), values, "k.", ms=6)
    ax.set_xticks(range(len(names)), [n.replace("_", "\n") for n in names], fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_yscale("log")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig



# ------------------------------------------------------------------------------------------------
# Notebook 02's claims as results: GMD-B1…B3, each a :class:`~repro.claims.result.ClaimResult`.
#
# The experiments are B1's round trip and sensitivity study, B2's location imputation and
# B3's Table B.1 (``measurements``); these run them at the notebook's :class:`Settings`,
# build the fitness-
# gate records of the models behind B2 and B3 (``model_gates``, gates version 3), runs each
# claim's controls and returns what its registered rule reads with the sidecar's headline,
# notes and extra values; the notebook then calls ``record(ctx, result)``.
# ------------------------------------------------------------------------------------------------

#: each root representation's role in GMD-B2 and B3 (``core.gates.ROLES``): HumanML3D's
#: relative root is what GMD's ablations start from and the absolute root what they compare
#: against it, so the sample gates judge the relative-root models only
REPRESENTATION_ROLES = {"relative": "reference", "absolute": "treatment"}


#: the real HumanML3D clip B1 also measures, where ``paths.humanml3d_sample_dir`` holds it
REAL_CLIP = "012314"


#: the rotation changes δω whose first-order (Jacobian) prediction B1 checks
LINEARISATION_DELTAS = (0.01, 0.1, 0.5)


#: a figure's path, as ``ClaimResult.figures`` takes it
FigurePath = str | os.PathLike


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


# ----------------------------------------------------------------------------------- GMD-B1

def real_clip_file() -> Path:
    """Where the real clip :data:`REAL_CLIP` would be (relative-root features, .npy)."""
    return paths.humanml3d_sample_dir() / "new_joint_vecs" / f"{REAL_CLIP}.npy"


@dataclass
class B1Study:
    """GMD-B1 on the stand-in test clips (and the real clip where present): the round trips
    (``root_representation.round_trip``), the sensitivity study (``sensitivity_study``) and
    the first-order error of a rotation change on the clip that travels furthest."""

    setup: SensitivitySetup
    clip_ids: list[str]
    clips: list[np.ndarray]
    trips: dict[str, RoundTrip]
    sensitivity: SensitivityResult
    real: np.ndarray | None
    real_sensitivity: SensitivityResult | None
    linearisation: np.ndarray

    @property
    def round_trip_max_error(self) -> float:
        """The registered ``round_trip_max_error``: the largest over every clip."""
        return max(t.max_error for t in self.trips.values())

    @property
    def walker(self) -> int:
        """The index of the clip that travels furthest after the perturbed frame."""
        return int(np.argmax(self.sensitivity.path_length))

    @property
    def real_measurements(self) -> dict[str, float] | None:
        """The sensitivity measurements of the real clip; None where it is absent."""
        return None if self.real_sensitivity is None else self.real_sensitivity.measurements()

    def measured(self) -> dict[str, float]:
        """Exactly what GMD-B1's rule reads."""
        return {"round_trip_max_error": self.round_trip_max_error,
                **self.sensitivity.measurements()}


def b1_study(dataset_root: Path, settings: Settings,
             setup: SensitivitySetup | None = None) -> B1Study:
    """GMD-B1's measurements: the first ``settings.sensitivity_clips`` test clips of at least
    ``setup.window`` frames, round-tripped and perturbed (float64), and the real clip where
    it is present."""
    setup = SensitivitySetup() if setup is None else setup
    clip_ids, clips = load_clips(dataset_root, "test", min_frames=setup.window,
                                 n=settings.sensitivity_clips)
    trips = {cid: round_trip(c) for cid, c in zip(clip_ids, clips, strict=True)}
    real_file = real_clip_file()
    real = np.load(real_file) if real_file.is_file() else None
    real_sensitivity = None
    if real is not None:
        trips[f"{REAL_CLIP} (real)"] = round_trip(real)
        real_sensitivity = sensitivity_study([real], setup, [REAL_CLIP])
    sensitivity = sensitivity_study(clips, setup, clip_ids)
    walker = clips[int(np.argmax(sensitivity.path_length))]
    linearisation = linearisation_error(walker, setup.early_frame, LINEARISATION_DELTAS)
    return B1Study(setup, clip_ids, clips, trips, sensitivity, real, real_sensitivity,
                   linearisation)


def round_trip_markdown(study: B1Study) -> str:
    """The round trips of the first five stand-in clips (and of the real clip), as a table;
    a note instead of the real clip where it is absent."""
    shown = list(study.trips.items())[:5]
    if study.real is None:
        note = (f"*Note: the real HumanML3D clip {real_clip_file()} is absent here; its part "
                "is skipped.*\n\n")
        real = ""
    else:
        shown.append((f"{REAL_CLIP} (real)", study.trips[f"{REAL_CLIP} (real)"]))
        note, real = "", f" and the real clip {REAL_CLIP}"
    rows = [[name, f"{t.frames}", f"{t.rel_abs_rel:.2e}", f"{t.abs_rel_abs:.2e}",
             f"{t.joints:.2e}"] for name, t in shown]
    return (note + f"Round trips (float64) on {len(study.clips)} stand-in clips{real}, first "
            "five shown:\n\n" + markdown_table(["clip", "frames", "rel→abs→rel", "abs→rel→abs",
                                                "joints rel vs abs (m)"], rows))


def b1_figures(study: B1Study, ctx: RunContext) -> list[Path]:
    """B1's figures, saved: the walker in both representations (and the real clip), and the
    displacement curves (``figures.plot_representations``, ``plot_sensitivity``)."""
    walker = study.clips[study.walker]
    fig = plot_representations(
        walker, study.setup, f"stand-in clip {study.clip_ids[study.walker]} in both "
        "representations")
    saved = [save_figure(fig, ctx.figure_path("gmd_b1_representations.png"))]
    if study.real is not None:
        fig = plot_representations(study.real, study.setup,
                                   f"real HumanML3D clip {REAL_CLIP} (first 60 frames)")
        saved.append(save_figure(fig, ctx.figure_path("gmd_b1_representations_real.png")))
    fig = plot_sensitivity(study.sensitivity, walker, study.real_sensitivity)
    saved.append(save_figure(fig, ctx.figure_path("gmd_b1_sensitivity.png")))
    return saved


def b1_result(study: B1Study, *, figures: Sequence[FigurePath], seed: int) -> ClaimResult:
    """GMD-B1: round trip, late-frame displacement in rel against abs, and rel's growth from
    gap 1 to the last gap (deterministic: no seed involved beyond the record's)."""
    measured = study.measured()
    growth_rel = study.sensitivity.growth("relative")
    return ClaimResult(
        "GMD-B1", measured, seeds=[seed], figures=list(figures),
        headline=(f"round trip {study.round_trip_max_error:.1e}; late-frame displacement rel "
                  f"{measured['rel_late_displacement']:.3f} m vs abs "
                  f"{measured['abs_late_displacement']:.3f} m; rel growth ×{growth_rel:.2f} "
                  f"from gap 1 to {study.setup.gaps[-1]}"),
        notes=("Deterministic (no seed involved). Stand-in clips: first 60 frames of "
               f"{len(study.clips)} test clips; perturbed frame 5; δω = 0.01 half-angle/frame, "
               "δv = 0.01 m/frame on x and z (abs: the same δ on heading, x, z); late frames = "
               "last 20 of the window; growth = displacement at gap 54 / gap 1. A "
               "linear-velocity change shifts every later frame by the same δv (no growth); a "
               "rotation change turns the rest of the path about p_i, so its effect grows with "
               "the distance travelled."),
        extra={"summary": study.sensitivity.summary(), "clips": study.clip_ids,
               "round_trip": {k: vars(v) for k, v in study.trips.items()},
               "real_clip": (None if study.real_sensitivity is None
                             else study.real_sensitivity.summary()),
               "linearisation_error_rotation_0.01_0.1_0.5": study.linearisation.tolist()})


def b1_reading(study: B1Study) -> str:
    """B1's "Reading" paragraph (``reading_b1``) from the study's numbers."""
    real = study.real_sensitivity
    return reading_b1(
        round_trip_error=study.round_trip_max_error,
        joints_error=max(t.joints for t in study.trips.values()),
        summary=study.sensitivity.summary(), late_gap=int(study.setup.gaps[-1]),
        growth=study.sensitivity.growth("relative"),
        real_growth=None if real is None else real.growth("relative"),
        linearisation=study.linearisation, deltas=list(LINEARISATION_DELTAS))


# ----------------------------------------------------------------------------------- GMD-B2

def b2_runs(trajectory_models: Mapping[str, Mapping[int, TrainedGMD]], test: MotionWindows,
            seeds: Sequence[int], settings: Settings,
            ) -> tuple[dict[int, LocationTask], dict[int, dict[str, ImputationRun]]]:
    """Per seed, ``settings.targets`` waypoint + goal pairs from the relative-root ``test``
    windows (``location_task``) and every method of
    ``METHODS`` toward them (``impute_locations``: GMD's stop step and
    clamp), all from the seed's noise: (tasks, runs), each keyed by seed."""
    tasks, runs = {}, {}
    for s in seeds:
        tasks[s] = location_task(test, settings.targets, seed=s)
        models = {rep: trajectory_models[rep][s] for rep in REPRESENTATIONS}
        runs[s] = impute_locations(models, tasks[s], seed=s, stop_t=settings.guidance_stop_t,
                                   clip_x0=settings.x0_clamp)
    return tasks, runs


def b2_table_markdown(runs: Mapping[int, Mapping[str, ImputationRun]], seeds: Sequence[int],
                      targets: int, seconds: float) -> str:
    """Every method's errors and path changes, the mean over seeds."""
    columns = ["location_error", "waypoint_error", "goal_error", "root_acceleration",
               "path_change_off_target"]
    rows = []
    for method in METHODS:
        per_seed = [runs[s][method].summary() for s in seeds]
        rows.append([method] + [np.mean([p[c] for p in per_seed]) for c in columns])
    return (f"Mean over {len(seeds)} seeds × {targets} samples (sampling {seconds:.1f} s):\n\n"
            + markdown_table(["method", "location error (m)", "waypoint (m)", "goal (m)",
                              "root acceleration (m/s²)",
                              "path change ≥3 frames from the targets (m)"], rows))


def b2_model_records(trajectory_models: Mapping[str, Mapping[int, TrainedGMD]],
                     runs: Mapping[int, Mapping[str, ImputationRun]], windows: Windows,
                     seeds: Sequence[int]) -> list[dict[str, Any]]:
    """The trajectory models' ``gmd_trajectory`` gate records: held-out x̂0 error in their own
    representation and the path length of their unguided runs (same noise) against the test
    windows'. Every part of GMD-B2 rests on both representations' models (reads: None)."""
    reference = {rep: model_gates.trajectory_gate_values(
        windows[rep]["test"].space("trajectory"), windows[rep]["test"].trajectory())
        for rep in REPRESENTATIONS}
    return [model_gates.gmd_model_record(
        trajectory_models[rep][s], family="gmd_trajectory", reference=reference[rep],
        label=rep, role=REPRESENTATION_ROLES[rep], arm=rep,
        values={**model_gates.trajectory_gate_values(
            trajectory_models[rep][s], runs[s][f"{short_label(rep)}_unguided"].samples),
            **model_gates.denoising_gate_values(trajectory_models[rep][s],
                                                windows[rep]["test"], windows[rep]["train"],
                                                seed=s)})
        for rep in REPRESENTATIONS for s in seeds]


#: GMD-B2's A/A slots: the abs (treatment) arms filled by the rel (reference) copy's errors;
#: the threshold part (0.1 m − abs imputation error) reads the copy's imputation error
B2_SLOTS = (Slot("abs_imputation_error", "rel_imputation_error", "imputation_error",
                 part="abs_imputes_better", sign=-1),
            Slot("abs_guidance_error", "rel_guidance_error", "guidance_error",
                 part="abs_guides_better", sign=-1))


def _b2_run_reading(runs: Mapping[str, ImputationRun]) -> dict[str, np.ndarray]:
    return {"imputation_error": runs["rel_imputation"].location_error.astype(np.float64),
            "guidance_error": runs["rel_guidance"].location_error.astype(np.float64)}


def b2_aa_readings(runs: Mapping[int, Mapping[str, ImputationRun]],
                   tasks: Mapping[int, LocationTask],
                   trajectory_models: Mapping[str, Mapping[int, TrainedGMD]],
                   test: MotionWindows, seeds: Sequence[int], settings: Settings) -> AAReadings:
    """GMD-B2's A/A runs (``controls.aa_readings``): the relative-root trajectory model (the
    reference arm) of seed s and its copy of the next seed, imputing and guiding toward seed
    s's targets from seed s's noise (per target and frame location errors); the own model's
    runs are the experiment's. A one-seed run's extra pairing draws its task from ``test``.

    The imputation errors are read by a ratio part (log rel / abs, blind to a common scale)
    and by a threshold part (0.1 m − abs): so both arms' imputation readings are scaled by one
    factor that puts the own models' mean at the 10 cm threshold (:data:`B2_THRESHOLD`), and
    the null sits at both parts' boundaries with the A/A's own spread (the positive's
    e^{−2δ} on the abs arm then moves the threshold part by ≈ 2δ: 0.1 m × (1 − 0.81))."""
    reference = dict(trajectory_models["relative"])

    def reading(model_seed: int, pairing_seed: int) -> dict[str, np.ndarray]:
        if model_seed == pairing_seed and model_seed in runs:
            return _b2_run_reading(runs[model_seed])
        task = (tasks[pairing_seed] if pairing_seed in tasks
                else location_task(test, settings.targets, seed=pairing_seed))
        return _b2_run_reading(impute_locations(
            {"relative": reference_model(reference, model_seed)}, task, seed=pairing_seed,
            stop_t=settings.guidance_stop_t, clip_x0=settings.x0_clamp,
            representations=("relative",)))

    found = aa_readings(reading, seeds)
    own = [float(np.mean(found.own[s]["imputation_error"])) for s, _ in found.pairs]
    scale = B2_THRESHOLD / float(np.mean(own)) if np.mean(own) > 0 else 1.0

    def at_threshold(reading: Mapping[int, Any]) -> dict[int, Any]:
        return {s: {**r, "imputation_error": np.asarray(r["imputation_error"]) * scale}
                for s, r in reading.items()}

    return AAReadings(found.pairs, at_threshold(found.own), at_threshold(found.copy))


#: the registered threshold of GMD-B2's ``abs_imputation_below_10cm`` part (m)
B2_THRESHOLD = 0.1


def b2_result(runs: Mapping[int, Mapping[str, ImputationRun]],
              tasks: Mapping[int, LocationTask],
              trajectory_models: Mapping[str, Mapping[int, TrainedGMD]], test: MotionWindows,
              seeds: Sequence[int], settings: Settings, *, figures: Sequence[FigurePath],
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-B2: location error of imputation and of guidance in each representation, like for
    like, with its A/A controls (:func:`b2_aa_readings`: the relative-root model against an
    independently trained copy toward the same targets; the positive with 2δ planted)."""
    sampling = settings.sampling_parameters()
    measured = registered_measurements(dict(runs))
    summary = {m: {s: runs[s][m].summary() for s in seeds} for m in METHODS}
    mean = {m: float(np.mean(measured[f"{m}_error"])) for m in REGISTERED_METHODS}
    controls = aa_controls("GMD-B2", b2_aa_readings(runs, tasks, trajectory_models, test,
                                                    seeds, settings),
                           B2_SLOTS, reference_arm="relative-root trajectory")
    for out in (controls.null, controls.positive):   # the rule's two further names
        out["rel_location_error"] = out["rel_guidance_error"]
        out["abs_location_error"] = out["abs_imputation_error"]
    first = seeds[0]
    return ClaimResult(
        "GMD-B2", measured, seeds=seeds, settings=rule_settings.b2(settings),
        figures=list(figures), controls=controls, models=list(models),
        headline=(f"imputation: abs {mean['abs_imputation']:.3f} m vs rel "
                  f"{mean['rel_imputation']:.3f} m; guidance: abs {mean['abs_guidance']:.3f} "
                  f"m vs rel {mean['rel_guidance']:.3f} m ({len(seeds)} seeds × "
                  f"{settings.targets} samples, T = {sampling['num_timesteps']}, stop t = "
                  f"{sampling['guidance_stop_t']})"),
        notes=("Like for like: abs imputation (x/z entries of the two target frames replaced) "
               "vs rel imputation (root rotation and velocity of every frame replaced by the "
               "straight forward-facing path through both targets), and the same L1 goal "
               "guidance (s = 100) in both. Imputation and guidance act while t ≥ "
               f"{sampling['guidance_stop_t']} of T = {sampling['num_timesteps']}; ε model "
               f"x̂0 clamped to ±{sampling['x0_clamp']:g}. Model: "
               + describe(trajectory_models["absolute"][first].spec) + "; targets from test "
               f"windows (waypoint frame {tasks[first].waypoint_frame}, goal frame "
               f"{tasks[first].goal_frame})."),
        extra={"parameters": sampling, "per_method": summary,
               "controls_planted": controls.planted})


# ----------------------------------------------------------------------------------- GMD-B3

@dataclass
class B3Evaluation:
    """Table B.1's evaluator (trained once on the relative training windows, cached), those
    windows' features, the evaluation set (test windows, one caption each) and its Real row."""

    evaluator: Evaluator
    train_features: np.ndarray
    evaluation: measurements.EvaluationSet
    real_row: dict[str, float]


def b3_evaluation(relative: Mapping[str, MotionWindows], settings: Settings, *,
                  seed: int) -> B3Evaluation:
    """The evaluator of ``relative["train"]`` (``settings.evaluator_config()``), the
    ``settings.evaluation_windows`` test windows drawn with ``seed`` and their Real row
    (``measurements.ground_truth_row``)."""
    train = relative["train"]
    with torch.no_grad():
        train_features = train.features().numpy()
    evaluator = load_or_train_evaluator(train_features, np.full(len(train), train.frames),
                                        train.captions, settings.evaluator_config())
    evaluation = measurements.evaluation_set(relative["test"], settings.evaluation_windows,
                                             seed=seed)
    real_row = measurements.ground_truth_row(evaluator, evaluation, train_features, seed=seed)
    return B3Evaluation(evaluator, train_features, evaluation, real_row)


def b3_rows(motion_models: Mapping[str, Mapping[int, TrainedGMD]], b3: B3Evaluation,
            seeds: Sequence[int]) -> dict[str, list[dict[str, float]]]:
    """Per representation, one Table B.1 row per seed: one sample per evaluation caption with
    classifier-free guidance at GMD's scale (``measurements.generate_for_captions``), scored by
    ``measurements.table_row``."""
    rows: dict[str, list[dict[str, float]]] = {rep: [] for rep in REPRESENTATIONS}
    for s in seeds:
        for rep in REPRESENTATIONS:
            generated = measurements.generate_for_captions(
                motion_models[rep][s], b3.evaluation.captions, seed=s,
                guidance_scale=GMD_CFG_SCALE)
            rows[rep].append(measurements.table_row(b3.evaluator, generated, b3.evaluation, seed=s))
    return rows


def b3_model_records(motion_models: Mapping[str, Mapping[int, TrainedGMD]], b3: B3Evaluation,
                     windows: Windows, seeds: Sequence[int], *,
                     seed: int) -> list[dict[str, Any]]:
    """The motion models' ``gmd_motion`` records (held-out x̂0 error) and then the evaluator's
    (R@3 of the evaluation windows with their captions, trivial fakes' FID); every part of
    GMD-B3 reads every one."""
    samples = model_gates.sample_gate_data(windows["relative"]["test"], seed=seed)

    def values(rep: str, s: int) -> dict[str, float]:
        model = motion_models[rep][s]
        found = model_gates.denoising_gate_values(model, windows[rep]["test"],
                                                  windows[rep]["train"], seed=s)
        if REPRESENTATION_ROLES[rep] == "reference":
            found.update(model_gates.motion_sample_values(model, samples, seed=s))
        return found

    records = [model_gates.gmd_model_record(
        motion_models[rep][s], family="gmd_motion", label=rep, role=REPRESENTATION_ROLES[rep],
        arm=rep, reference=samples.values, values=values(rep, s))
        for rep in REPRESENTATIONS for s in seeds]
    evaluation = b3.evaluation
    evaluator_record = model_gates.evaluator_model_record(
        b3.evaluator, values=model_gates.evaluator_gate_values(
            b3.evaluator, evaluation.features, evaluation.lengths, evaluation.captions,
            seed=seed, train_features=b3.train_features, samples=len(evaluation)))
    return [*records, evaluator_record]


def b3_result(rows: Mapping[str, list[dict[str, float]]], b3: B3Evaluation,
              motion_models: Mapping[str, Mapping[int, TrainedGMD]], seeds: Sequence[int],
              settings: Settings, *, figures: Sequence[FigurePath],
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-B3: Table B.1's FID, R@3 and Diversity per seed in each representation, with its
    controls (``b3_controls``: degraded evaluation windows, calibrated as
    ``settings.b3_control_options`` says)."""
    rows = dict(rows)
    measured = measurements.registered_measurements(b3.real_row, rows)
    mean = {k: float(np.mean(v)) for k, v in measured.items()}
    controls = b3_controls(b3.evaluator, b3.evaluation, b3.real_row, seeds,
                           **settings.b3_control_options)
    return ClaimResult(
        "GMD-B3", measured, seeds=seeds, settings=rule_settings.b3(settings),
        figures=list(figures), controls=controls, models=list(models),
        headline=(f"FID rel {mean['fid_rel']:.3f} vs abs {mean['fid_abs']:.3f}; R@3 rel "
                  f"{mean['r_precision_top3_rel']:.3f} vs abs "
                  f"{mean['r_precision_top3_abs']:.3f}; Diversity rel "
                  f"{mean['diversity_rel']:.3f} vs abs {mean['diversity_abs']:.3f} (real "
                  f"{mean['diversity_real']:.3f}); {len(seeds)} seeds, CFG s = "
                  f"{GMD_CFG_SCALE:g}"),
        notes=("Model: " + describe(motion_models["absolute"][seeds[0]].spec) + ", text "
               f"condition = bag of words, classifier-free guidance at sampling with s = "
               f"{GMD_CFG_SCALE:g} (GMD's); evaluator: the package's tiny contrastive one "
               f"trained on the relative training windows; {len(b3.evaluation)} test windows, "
               "one caption each; abs samples converted to rel before evaluation. The paper's "
               "text calls the abs/rel change a trade-off between FID and R-precision, but its "
               "Table B.1 has abs better on FID, R-precision and Diversity: the rule tests the "
               "table's directions."),
        extra={"real": b3.real_row, "rows": measurements.by_label(rows),
               "summary": measurements.by_label({rep: measurements.summarise_rows(rows[rep])
                                                 for rep in REPRESENTATIONS}),
               "paper_table_b1": measurements.PAPER_TABLE_B1,
               "classifier_free_scale": GMD_CFG_SCALE,
               "evaluation_windows": len(b3.evaluation),
               "controls_planted": controls.planted})


def _b3_why(settings: Settings) -> str:
    """Why this scale runs no part of GMD-B3 (the registered reasons, each once)."""
    return "; ".join(dict.fromkeys(settings.b3_not_run.values()))


def b3_not_run_markdown(settings: Settings) -> str:
    """A markdown line where GMD-B3's experiment would be: that this scale does not run it
    and why (``Settings.b3_not_run``)."""
    return f"*GMD-B3 is not run at the {settings.scale} scale: {_b3_why(settings)}.*"


def b3_not_run_result(settings: Settings, seeds: Sequence[int]) -> ClaimResult:
    """GMD-B3 at a scale that runs none of its parts (``Settings.runs_b3`` false): nothing
    measured, no models, no controls, every part not run with its registered reason
    (``settings.not_run``); the rule is rendered from the settings a run of it would use
    (``seeds``, the evaluation windows, T, GMD's CFG scale), so the record says what was not
    run."""
    if settings.runs_b3:
        raise ValueError(f"the {settings.scale} scale runs GMD-B3: record its measurements "
                         "(b3_result)")
    why = _b3_why(settings)
    return ClaimResult(
        "GMD-B3", {}, seeds=list(seeds), settings=rule_settings.b3(settings),
        not_run=settings.b3_not_run,
        headline=f"not run at the {settings.scale} scale (each part says why)",
        notes=(f"Not run at the {settings.scale} scale (a registered cut, "
               "repro.gmd.settings.STANDARD_NOT_RUN): no relative- or absolute-root motion "
               "model is trained, no evaluator, no sample drawn; every part "
               f"({', '.join(B3_PARTS)}) is recorded inconclusive with why: {why}. The rule "
               "states what a run of it measures."))
