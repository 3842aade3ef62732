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
modules of ``repro.gmd``: the exact round trip and the sensitivity study (GMD-B1) and the
notebook's fixed settings (:class:`Settings`). Location imputation (GMD-B2) is
``repro.gmd.location_imputation``, Table B.1 (GMD-B3) ``repro.gmd.table_b1``; the figures are
in ``repro.gmd.figures``. Representations are named as ``motion.humanml3d.REPRESENTATIONS``
("relative", "absolute"); "rel"/"abs" (``windows.short_label``) only name measurements.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from repro.gmd import paper_settings
from repro.gmd.guidance import default_stop_step
from repro.gmd.models import (
    MOTION_TRAINING,
    STANDARD_MOTION_TRAINING,
    STANDARD_TRAJECTORY_TRAINING,
    TRAJECTORY_TRAINING,
    GMDModelSpec,
    training_fields,
)
from repro.gmd.run_seeds import seeds_of
from repro.gmd.windows import REPRESENTATIONS, DataConfig, DataDir, short_label
from repro.infra.context import check_scale
from repro.models.evaluator import EvaluatorConfig
from repro.motion.features import (
    absolute_features_to_joints,
    absolute_to_relative_root,
    features_to_joints,
    recover_root,
    relative_to_absolute_root,
)

__all__ = [
    "ROOT_PARAMETERS",
    "RoundTrip",
    "SensitivityResult",
    "SensitivitySetup",
    "Settings",
    "global_root_xz",
    "linearisation_error",
    "load_clips",
    "perturbation_displacement",
    "root_jacobian",
    "round_trip",
    "sensitivity_study",
]

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
        against (registry v4; v3 compared rel with abs's late frames, which are 0 by
        construction)."""
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

@dataclass(frozen=True)
class Settings:
    """Every size and step count of notebook 02 at one scale, fixed before any verdict was seen.

    GMD-B2 (paper scale) uses the guidance experiments' trajectory model (:meth:`trajectory_spec`:
    ε prediction, ``paper_settings.TRAJECTORY_ARCHITECTURE``, T = 1000 cosine), sampled with
    GMD's stop step t = 20 and ±6 clamp of x̂0 (``paper_settings``); GMD-B3 a text-conditioned
    x0 motion model (GMD's motion model predicts x0; ``paper_settings.MOTION_ARCHITECTURE``),
    both trained to convergence (``models.training_fields``; ``trajectory_steps`` /
    ``motion_steps`` are the step caps), the motion model sampled with
    classifier-free guidance at GMD's scale (``repro.gmd.cfg``). ``seeds`` (B2) and
    ``motion_seeds`` (B3) come from ``run_seeds.seeds_of``. The standard scale (docs/COMPUTE.md
    §3) trains the standard architectures for a fixed step count, T = 100 for every model (the
    stop step at the same fraction, 2), 3 seeds each and 128 B3 samples. Quick mode shrinks
    everything, T included (a test of the code, never a result).
    """

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
                       diffusion_steps=paper_settings.STANDARD_DIFFUSION_STEPS,
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
        """T of the B2 trajectory models: GMD's 1000 at the paper scale, ``diffusion_steps``
        otherwise (standard 100, quick 20)."""
        if self.scale == "paper":
            return paper_settings.GUIDANCE_DIFFUSION_STEPS
        return self.diffusion_steps

    @property
    def guidance_stop_t(self) -> int:
        """Imputation and guidance act while t ≥ this: GMD's 20 of T = 1000, scaled to a
        quick run's T (``guidance.default_stop_step``)."""
        steps = self.trajectory_diffusion_steps
        if steps == paper_settings.GUIDANCE_DIFFUSION_STEPS:
            return paper_settings.GUIDANCE_STOP_T
        return default_stop_step(steps)

    @property
    def x0_clamp(self) -> float:
        """GMD's clamp of the ε trajectory model's x̂0 (±6, ``paper_settings.X0_CLAMP``)."""
        return paper_settings.X0_CLAMP

    @property
    def b3_control_options(self) -> dict[str, int]:
        """The calibration of GMD-B3's positive control (``controls_b3.b3_controls``'
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
                            schedule=paper_settings.GUIDANCE_SCHEDULE,
                            **training_fields("trajectory", scale=self.scale,
                                              step_cap=self.trajectory_steps, seed=seed))

    def motion_spec(self, representation: str, seed: int,
                    data_dir: DataDir = None) -> GMDModelSpec:
        return GMDModelSpec(task="motion", prediction="x0", text_conditioned=True,
                            data=self.data(representation, data_dir),
                            diffusion_steps=self.diffusion_steps,
                            **training_fields("motion", scale=self.scale,
                                              step_cap=self.motion_steps, seed=seed))


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
