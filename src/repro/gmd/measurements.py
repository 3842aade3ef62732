"""Motion quality of tiny-GMD samples: jitter, foot skating, evaluator inputs (``core.metrics``)."""

from __future__ import annotations

from typing import Literal

import numpy as np
import torch
from torch import Tensor

from repro.core import metrics
from repro.gmd.guidance import sample
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import FeatureSpace
from repro.models.evaluator import Evaluator
from repro.motion.features import FPS
from repro.motion.skeleton import NUM_JOINTS

__all__ = ["evaluator_inputs", "foot_skating_of", "jitter_of", "motion_fid", "sample_quality",
           "unguided_sample_quality"]


def _root_as_joints(root: np.ndarray) -> np.ndarray:
    # metrics.jitter averages over 22 joints: 22 copies of the root give the root's own value
    return np.repeat(root[:, :, None, :], NUM_JOINTS, axis=2)


def jitter_of(trained: TrainedGMD | FeatureSpace, x: Tensor,
              part: Literal["auto", "joints", "root"] = "auto") -> metrics.Jitter:
    """Mean acceleration (m/s²) and jerk (m/s³) of samples (B, C, T) (``metrics.jitter``):
    of all recovered joints for the motion task, of the root path for the trajectory task
    (``part`` forces one; a trajectory sample has only a root)."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    if part == "auto":
        part = "joints" if space.task == "motion" else "root"
    with torch.no_grad():
        if part == "joints":
            points = space.joints(x.detach()).cpu().double().numpy()
        else:
            points = _root_as_joints(space.root_positions(x.detach()).cpu().double().numpy())
    return metrics.jitter(points, fps=FPS)


def foot_skating_of(trained: TrainedGMD | FeatureSpace, x: Tensor) -> float:
    """Mean horizontal foot speed in contact (m/s, ``metrics.foot_skating``), motion task."""
    space = trained.space if isinstance(trained, TrainedGMD) else trained
    with torch.no_grad():
        joints = space.joints(x.detach()).cpu().double().numpy()
    return metrics.foot_skating(joints, fps=FPS)



def evaluator_inputs(space: TrainedGMD | FeatureSpace,
                     x: Tensor) -> tuple[np.ndarray, list[int]]:
    """(features (B, T, 263) float32 in HumanML3D's relative representation, lengths) of
    motion-task samples, as ``evaluator.Evaluator.embed_motions`` takes them."""
    space = space.space if isinstance(space, TrainedGMD) else space
    with torch.no_grad():
        features = space.relative_features(x.detach().cpu()).numpy().astype(np.float32)
    return features, [features.shape[1]] * features.shape[0]


def motion_fid(space: TrainedGMD | FeatureSpace, x: Tensor, evaluator: Evaluator,
               test_embeddings: np.ndarray) -> float:
    """FID (``metrics.fid``) of motion-task samples (B, 263, T) against ``test_embeddings``,
    through the evaluator's embedding of their relative-root features."""
    features, lengths = evaluator_inputs(space, x)
    return float(metrics.fid(evaluator.embed_motions(features, lengths), test_embeddings))


def sample_quality(joints: np.ndarray | Tensor, *, fid: float | None = None) -> dict[str, float]:
    """Foot skating (mean horizontal foot speed in contact, m/s, ``metrics.foot_skating``) and
    joint jerk (mean ‖Δ³p‖·fps³, m/s³, ``metrics.jitter``) of joint positions (B, T, 22, 3) in
    metres, with ``fid`` when given: the quantities GMD-A4, C4 and F1 compare (gates versions 1
    and 2 gated on them; the pilots and ``denoiser_diagnostics.noise_floor`` still measure them)."""
    points = joints.detach().cpu().double().numpy() if isinstance(joints, Tensor) \
        else np.asarray(joints, dtype=np.float64)
    values = {"foot_skating": float(metrics.foot_skating(points, fps=FPS)),
              "joint_jerk": float(metrics.jitter(points, fps=FPS).jerk)}
    if fid is not None:
        values["fid"] = float(fid)
    return values


def unguided_sample_quality(trained: TrainedGMD, n: int, *, seed: int, evaluator: Evaluator,
                            test_embeddings: np.ndarray) -> dict[str, float]:
    """:func:`sample_quality` of ``n`` unguided samples of a motion model (seed ``seed``; an ε
    model's x̂0 clamped as in GMD-A4) with their FID against ``test_embeddings``."""
    if trained.spec.task != "motion":
        raise ValueError(f"need a motion model, got a {trained.spec.task} model")
    x = sample(trained, n, seed=seed)
    fid = motion_fid(trained, x, evaluator, test_embeddings)
    with torch.no_grad():
        joints = trained.space.joints(x)
    return sample_quality(joints, fid=fid)
