"""Evaluation metrics with their standard definitions (REFERENCE.md "Metrics").

Embedding metrics follow Guo et al. 2022 (text-to-motion evaluation): FID, R-precision and
MM-Dist in batches of 32, Diversity (300 pairs), MultiModality (10 pairs per text). The
TMR-style score and the transition distance follow STMC's MTT evaluation (nv-tlabs/stmc).
Foot skating follows GMD/OmniControl. Everything here is numpy in, floats out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
import scipy.linalg
from scipy.ndimage import uniform_filter1d
from scipy.spatial.distance import cdist

from repro.motion.skeleton import JOINT_INDEX, NUM_JOINTS

#: jitter added to both covariances when √(Σ1Σ2) is not finite (Guo et al., TMR, STMC).
FID_EPS = 1e-6
#: largest imaginary part of diag(√(Σ1Σ2)) that is treated as round-off and dropped.
FID_MAX_IMAGINARY = 1e-3
FOOT_JOINTS_FOR_SKATING = (JOINT_INDEX["L_foot"], JOINT_INDEX["R_foot"])


def _matrix(name: str, x: np.ndarray, ndim: int = 2) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return x


def _paired(a_name: str, a: np.ndarray, b_name: str, b: np.ndarray) -> tuple[np.ndarray, ...]:
    a, b = _matrix(a_name, a), _matrix(b_name, b)
    if a.shape != b.shape:
        raise ValueError(f"{a_name} {a.shape} and {b_name} {b.shape} must have the same shape")
    return a, b


# --- FID ---------------------------------------------------------------------------------


def _gaussian(mu: np.ndarray, sigma: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    mu = _matrix(f"mu{name}", np.atleast_1d(mu), 1)
    sigma = _matrix(f"sigma{name}", np.atleast_2d(sigma), 2)
    if sigma.shape != (mu.size, mu.size):
        raise ValueError(f"sigma{name} has shape {sigma.shape}, expected {(mu.size, mu.size)}")
    return mu, sigma


def _sqrtm_product(sigma1: np.ndarray, sigma2: np.ndarray) -> np.ndarray:
    root = scipy.linalg.sqrtm(sigma1 @ sigma2)
    if not np.all(np.isfinite(root)):
        offset = FID_EPS * np.eye(sigma1.shape[0])
        root = scipy.linalg.sqrtm((sigma1 + offset) @ (sigma2 + offset))
    if np.iscomplexobj(root):
        imaginary = np.max(np.abs(np.diagonal(root).imag))
        if imaginary > FID_MAX_IMAGINARY:
            raise ValueError(
                f"√(Σ1Σ2) has an imaginary diagonal part of {imaginary:.3g}: the covariances "
                "are not positive semi-definite (too few samples for the embedding size?)"
            )
        root = root.real
    return root


def frechet_distance(mu1: np.ndarray, sigma1: np.ndarray, mu2: np.ndarray,
                     sigma2: np.ndarray) -> float:
    """Fréchet distance of N(μ1, Σ1) and N(μ2, Σ2): ‖μ1−μ2‖² + Tr(Σ1) + Tr(Σ2) − 2·Tr(√(Σ1Σ2)).

    The square root is scipy's; 1e-6·I is added to both covariances if it is not finite, a
    negligible imaginary part (≤ 1e-3 on the diagonal) is dropped and a larger one raises.
    """
    mu1, sigma1 = _gaussian(mu1, sigma1, "1")
    mu2, sigma2 = _gaussian(mu2, sigma2, "2")
    if mu1.shape != mu2.shape:
        raise ValueError(f"mu1 {mu1.shape} and mu2 {mu2.shape} have different dimensions")
    diff = mu1 - mu2
    root = _sqrtm_product(sigma1, sigma2)
    return float(diff @ diff + np.trace(sigma1) + np.trace(sigma2) - 2.0 * np.trace(root))


def embedding_statistics(features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and (unbiased, ``np.cov``) covariance of embeddings (N, D), N ≥ 2."""
    features = _matrix("features", features)
    if features.shape[0] < 2:
        raise ValueError(f"need at least 2 embeddings for a covariance, got {features.shape[0]}")
    return features.mean(axis=0), np.atleast_2d(np.cov(features, rowvar=False))


def fid(features_a: np.ndarray, features_b: np.ndarray) -> float:
    """FID between two sets of embeddings (N_a, D) and (N_b, D) (Guo et al. 2022)."""
    mu_a, sigma_a = embedding_statistics(features_a)
    mu_b, sigma_b = embedding_statistics(features_b)
    return frechet_distance(mu_a, sigma_a, mu_b, sigma_b)


def fid_as_printed_in_energymogen(mu1: np.ndarray, sigma1: np.ndarray, mu2: np.ndarray,
                                  sigma2: np.ndarray) -> float:
    """EnergyMoGen appendix G.2, Eq. 12 taken literally: ‖μ−μ̂‖² − Tr(Σ + Σ̂ − 2ΣΣ̂).

    WRONG, kept only for claim EMG-9: the trace term has the wrong sign and the product
    ΣΣ̂ lacks its matrix square root. It is not a distance: it is negative whenever
    Tr(Σ + Σ̂) > 2·Tr(ΣΣ̂) and the means agree (e.g. Σ = Σ̂ = ½I). Use ``frechet_distance``.
    """
    mu1, sigma1 = _gaussian(mu1, sigma1, "1")
    mu2, sigma2 = _gaussian(mu2, sigma2, "2")
    diff = mu1 - mu2
    return float(diff @ diff - np.trace(sigma1 + sigma2 - 2.0 * sigma1 @ sigma2))


def gaussian_fid_closed_form(mu1: np.ndarray, variances1: np.ndarray, mu2: np.ndarray,
                             variances2: np.ndarray) -> float:
    """FID of two Gaussians whose covariances commute: ‖Δμ‖² + Σ_i (√λ1_i − √λ2_i)².

    ``variances1``/``variances2`` are the eigenvalues of Σ1 and Σ2 in their shared eigenbasis
    (the diagonals, for diagonal covariances). Then √(Σ1Σ2) = Q diag(√(λ1λ2)) Qᵀ, and the
    trace terms collapse to a sum of squares.
    """
    mu1, mu2 = _matrix("mu1", np.atleast_1d(mu1), 1), _matrix("mu2", np.atleast_1d(mu2), 1)
    lam1 = _matrix("variances1", np.atleast_1d(variances1), 1)
    lam2 = _matrix("variances2", np.atleast_1d(variances2), 1)
    if not mu1.shape == mu2.shape == lam1.shape == lam2.shape:
        raise ValueError("mu1, variances1, mu2, variances2 must all have the same length")
    if np.any(lam1 < 0) or np.any(lam2 < 0):
        raise ValueError("variances must be non-negative")
    diff = mu1 - mu2
    return float(diff @ diff + np.sum((np.sqrt(lam1) - np.sqrt(lam2)) ** 2))


# --- text–motion matching ----------------------------------------------------------------


def r_precision(text_emb: np.ndarray, motion_emb: np.ndarray, batch_size: int = 32,
                top_k: int = 3, seed: int = 0) -> np.ndarray:
    """Top-1..k R-precision (Guo et al. 2022): hit rates, shape (top_k,).

    The pairs are shuffled and cut into batches of ``batch_size`` (an incomplete last batch is
    dropped, as Guo's loader does); in each batch every text ranks the batch's motions by
    Euclidean distance, and a hit at k means its own motion is among the k nearest.
    """
    text_emb, motion_emb = _paired("text_emb", text_emb, "motion_emb", motion_emb)
    n = text_emb.shape[0]
    if not 1 <= top_k <= batch_size:
        raise ValueError(f"top_k must be in 1..batch_size={batch_size}, got {top_k}")
    if n < batch_size:
        raise ValueError(f"R-precision needs at least batch_size={batch_size} pairs, got {n}")
    order = np.random.default_rng(seed).permutation(n)
    n_batches = n // batch_size
    hits = np.zeros(top_k)
    for b in range(n_batches):
        idx = order[b * batch_size:(b + 1) * batch_size]
        dist = cdist(text_emb[idx], motion_emb[idx])
        # rank of the matched motion = number of motions strictly closer than it
        rank = np.sum(dist < np.diagonal(dist)[:, None], axis=1)
        hits += np.array([np.sum(rank < k) for k in range(1, top_k + 1)])
    return hits / (n_batches * batch_size)


def mm_distance(text_emb: np.ndarray, motion_emb: np.ndarray) -> float:
    """MM-Dist (Guo's "matching score"): mean ‖t_i − m_i‖ over text–motion pairs; EnergyMoGen
    Eq. 13 with the text's feature t_i where it prints the real motion's (docs/ERRATA.md)."""
    text_emb, motion_emb = _paired("text_emb", text_emb, "motion_emb", motion_emb)
    return float(np.linalg.norm(text_emb - motion_emb, axis=1).mean())


matching_score = mm_distance


def diversity(emb: np.ndarray, n_pairs: int = 300, seed: int = 0) -> float:
    """Diversity (EnergyMoGen Eq. 14): mean distance over ``n_pairs`` random pairs.

    As Guo et al.: two index sets of size ``n_pairs`` drawn without replacement, paired
    in order (so N ≥ n_pairs is required).
    """
    emb = _matrix("emb", emb)
    n = emb.shape[0]
    if n_pairs < 1 or n < n_pairs:
        raise ValueError(f"diversity needs N ≥ n_pairs ≥ 1; got N={n}, n_pairs={n_pairs}")
    rng = np.random.default_rng(seed)
    first = rng.choice(n, n_pairs, replace=False)
    second = rng.choice(n, n_pairs, replace=False)
    return float(np.linalg.norm(emb[first] - emb[second], axis=1).mean())


def multimodality(emb_per_text: np.ndarray, n_pairs: int = 10, seed: int = 0) -> float:
    """MultiModality (Guo et al.): per text, mean distance over ``n_pairs`` pairs of its
    generations, averaged over texts. ``emb_per_text`` is (n_texts, n_gen, D), n_gen ≥ n_pairs.
    """
    emb = _matrix("emb_per_text", emb_per_text, 3)
    n_gen = emb.shape[1]
    if n_pairs < 1 or n_gen < n_pairs:
        raise ValueError(f"multimodality needs n_gen ≥ n_pairs ≥ 1; got {n_gen}, {n_pairs}")
    rng = np.random.default_rng(seed)
    first = rng.choice(n_gen, n_pairs, replace=False)
    second = rng.choice(n_gen, n_pairs, replace=False)
    return float(np.linalg.norm(emb[:, first] - emb[:, second], axis=2).mean())


def tmr_score(a: np.ndarray, b: np.ndarray) -> float:
    """TMR-style score (STMC/EnergyMoGen): mean over pairs of (cos(a_i, b_i) + 1)/2 ∈ [0, 1].

    M2T: a = motion, b = text embeddings; M2M: a = motion, b = ground-truth motion.
    """
    a, b = _paired("a", a, "b", b)
    norms = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
    if np.any(norms == 0):
        raise ValueError("tmr_score: an embedding has zero norm, its cosine is undefined")
    cos = np.sum(a * b, axis=1) / norms
    return float(np.mean((cos + 1.0) / 2.0))


# --- motion-level metrics on joints ------------------------------------------------------


def _joints(joints: np.ndarray, min_frames: int = 1) -> np.ndarray:
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim not in (3, 4) or joints.shape[-2:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must be (T, {NUM_JOINTS}, 3) or (B, T, {NUM_JOINTS}, 3), "
                         f"got {joints.shape}")
    if joints.shape[-3] < min_frames:
        raise ValueError(f"need at least {min_frames} frames, got {joints.shape[-3]}")
    if not np.all(np.isfinite(joints)):
        raise ValueError("joints contain NaN or infinite values")
    return joints if joints.ndim == 4 else joints[None]


def _frame_mask(batch: int, frames: int, lengths: Sequence[int] | None) -> np.ndarray:
    if lengths is None:
        return np.ones((batch, frames), dtype=bool)
    lengths = np.asarray(lengths)
    if lengths.shape != (batch,) or np.any(lengths < 1) or np.any(lengths > frames):
        raise ValueError(f"lengths must be {batch} values in 1..{frames}, got {lengths}")
    return np.arange(frames)[None] < lengths[:, None]


def ric_joints(features: np.ndarray) -> np.ndarray:
    """Joints in the body's own facing frame, root at the origin, from 263-d features.

    Returns (..., T, 22, 3): the root is (0, 0, 0) and joints 1–21 are the stored "ric"
    positions (features 4:67) with the root height (feature 3) subtracted from y. This is what
    STMC's transition distance compares (its local joints with the heading zeroed and the
    root subtracted); no heading or trajectory is involved.
    """
    features = np.asarray(features, dtype=np.float64)
    if features.ndim < 2 or features.shape[-1] != 263:
        raise ValueError(f"features must be (..., T, 263), got {features.shape}")
    body = features[..., 4:67].reshape(*features.shape[:-1], NUM_JOINTS - 1, 3).copy()
    body[..., 1] -= features[..., 3:4]
    root = np.zeros((*features.shape[:-1], 1, 3))
    return np.concatenate([root, body], axis=-2)


def transition_distance(joints: np.ndarray, transition_frames: Sequence[int]) -> float:
    """Transition distance (TEACH, as computed by STMC): at each transition frame t, the mean
    over joints of ‖j_t − j_{t−1}‖ on root-relative joints, averaged over transitions (m).

    ``joints`` (T, 22, 3) or (B, T, 22, 3) with the same transitions for the batch; the root
    joint is subtracted here. (STMC also removes the heading: pass ``ric_joints(features)``
    for exactly that. STMC's tables print the value ×100.)
    """
    joints = _joints(joints, min_frames=2)
    frames = np.asarray(transition_frames, dtype=int).reshape(-1)
    if frames.size == 0:
        raise ValueError("transition_frames is empty")
    if np.any(frames < 1) or np.any(frames >= joints.shape[1]):
        raise ValueError(f"transition frames must lie in 1..{joints.shape[1] - 1}, got {frames}")
    local = joints - joints[:, :, :1]
    step = np.linalg.norm(local[:, frames] - local[:, frames - 1], axis=-1)
    return float(step.mean())


def _foot_contact_and_speed(joints: np.ndarray, fps: float,
                            height_threshold: float) -> tuple[np.ndarray, np.ndarray]:
    feet = joints[:, :, FOOT_JOINTS_FOR_SKATING]  # (B, T, 2, 3)
    speed = np.linalg.norm(np.diff(feet[..., [0, 2]], axis=1), axis=-1) * fps  # (B, T-1, 2)
    low = feet[..., 1] < height_threshold
    contact = low[:, 1:] & low[:, :-1]
    return contact, speed


def foot_skating(joints: np.ndarray, fps: float = 20.0, height_threshold: float = 0.05,
                 lengths: Sequence[int] | None = None) -> float:
    """Mean horizontal foot speed while in contact (m/s), GMD/OmniControl style.

    A foot (left/right foot joints 10, 11) is in contact over a frame step when its height is
    below ``height_threshold`` (floor at y = 0) in both frames; the score is
    Σ contact·‖Δxz‖·fps / Σ contact over feet, steps and clips — GMD's ``skate_vel``
    weighted by contact, without its 5-frame smoothing. NaN when no foot ever touches.
    """
    joints = _joints(joints, min_frames=2)
    contact, speed = _foot_contact_and_speed(joints, fps, height_threshold)
    valid = _frame_mask(joints.shape[0], joints.shape[1], lengths)
    contact &= (valid[:, 1:] & valid[:, :-1])[..., None]
    if not contact.any():
        return float("nan")
    return float(np.sum(speed * contact) / np.sum(contact))


def foot_skating_ratio(joints: np.ndarray, fps: float = 20.0, height_threshold: float = 0.05,
                       velocity_threshold: float = 0.5, window: int = 5,
                       lengths: Sequence[int] | None = None) -> float:
    """GMD's skating ratio: fraction of frame steps in which some foot is in contact and moves
    faster than ``velocity_threshold`` (m/s), both at that step and averaged over ``window``
    steps (scipy ``uniform_filter1d``, zero padding, as GMD)."""
    joints = _joints(joints, min_frames=2)
    contact, speed = _foot_contact_and_speed(joints, fps, height_threshold)
    smooth = uniform_filter1d(speed, size=window, axis=1, mode="constant")
    skating = (contact & (speed > velocity_threshold) & (smooth > velocity_threshold)).any(-1)
    valid = _frame_mask(joints.shape[0], joints.shape[1], lengths)
    steps = valid[:, 1:] & valid[:, :-1]
    return float(np.sum(skating & steps) / np.sum(steps))


class Jitter(NamedTuple):
    """Mean joint acceleration (m/s²) and jerk (m/s³) magnitudes."""

    acceleration: float
    jerk: float


def jitter(joints: np.ndarray, fps: float = 20.0,
           lengths: Sequence[int] | None = None) -> Jitter:
    """Mean ‖a‖ and ‖j‖ over joints and frames, from finite differences of positions:
    a_t = (x_{t+1} − 2x_t + x_{t−1})·fps², j_t = third difference·fps³ (needs T ≥ 4)."""
    joints = _joints(joints, min_frames=4)
    valid = _frame_mask(joints.shape[0], joints.shape[1], lengths)
    if lengths is not None and np.min(lengths) < 4:
        raise ValueError("jitter needs every clip to have at least 4 frames")
    values = []
    for order in (2, 3):
        magnitude = np.linalg.norm(np.diff(joints, n=order, axis=1), axis=-1) * fps**order
        mask = valid[:, order:]  # a difference is valid when its last frame is
        values.append(float(np.sum(magnitude * mask[..., None]) / (mask.sum() * NUM_JOINTS)))
    return Jitter(*values)


def mean_speeds(joints: np.ndarray, fps: float = 20.0) -> tuple[float, float]:
    """(mean joint speed, mean horizontal root speed) in m/s of joints (B, T, 22, 3):
    ‖x_{t+1} − x_t‖·fps averaged over joints and frames, and the same of the root's x/z."""
    joints = _joints(joints, min_frames=2)
    step = np.linalg.norm(np.diff(joints, axis=1), axis=-1) * fps
    root = np.linalg.norm(np.diff(joints[:, :, 0, [0, 2]], axis=1), axis=-1) * fps
    return float(step.mean()), float(root.mean())


def motion_statistics(joints: np.ndarray, fps: float = 20.0) -> dict[str, float]:
    """What the sample gates compare between samples and data (``core.gates``, version 4):
    ``joint_speed`` and ``root_speed`` (:func:`mean_speeds`), ``joint_jerk`` (:func:`jitter`)
    and ``foot_skating`` (:func:`foot_skating`) of joints (B, T, 22, 3) in metres; and,
    reported beside them, ``foot_skating_ratio`` (:func:`foot_skating_ratio`, the field's
    number, comparable with published models')."""
    joint_speed, root_speed = mean_speeds(joints, fps)
    return {"joint_speed": joint_speed, "root_speed": root_speed,
            "joint_jerk": jitter(joints, fps).jerk, "foot_skating": foot_skating(joints, fps),
            "foot_skating_ratio": foot_skating_ratio(joints, fps)}


#: bootstrap resamples of the samples behind a sample gate's interval (``core.gates``)
GATE_RESAMPLES = 100


def motion_statistics_intervals(joints: np.ndarray, fps: float = 20.0, *,
                                resamples: int = GATE_RESAMPLES, seed: int = 0,
                                ) -> dict[str, list[float]]:
    """The sampling interval of each :func:`motion_statistics` value of joints (B, T, 22, 3):
    the statistic ± 1.96 × its bootstrap standard error over ``resamples`` resamples of the B
    clips with replacement (drawn with ``seed``): how far another draw of as many samples from
    the same model could put it. Keys ``<metric>_interval`` → [low, high]."""
    joints = _joints(joints, min_frames=4)
    point = motion_statistics(joints, fps)
    rng = np.random.default_rng(seed)
    draws = [motion_statistics(joints[rng.integers(0, len(joints), len(joints))], fps)
             for _ in range(int(resamples))]
    out = {}
    for metric, value in point.items():
        spread = 1.96 * float(np.std([d[metric] for d in draws], ddof=1))
        out[f"{metric}_interval"] = [float(value) - spread, float(value) + spread]
    return out


# --- replications ------------------------------------------------------------------------


def mean_and_ci95(values: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """(mean, 1.96·std/√n) over replications, std with ddof = 0 as in Guo et al.'s scripts."""
    values = _matrix("values", np.asarray(values, dtype=np.float64).reshape(-1), 1)
    if values.size == 0:
        raise ValueError("mean_and_ci95 needs at least one value")
    return float(values.mean()), float(1.96 * values.std() / np.sqrt(values.size))


def summarise_replications(
    replications: Sequence[Mapping[str, float]],
) -> dict[str, tuple[float, float]]:
    """{metric: (mean, ci95)} over replications, each a {metric: value} dict with the same
    keys (e.g. the outputs of ``repro.evaluator.evaluate_generated``)."""
    if not replications:
        raise ValueError("no replications to summarise")
    keys = list(replications[0])
    for i, rep in enumerate(replications):
        if set(rep) != set(keys):
            raise ValueError(f"replication {i} has keys {sorted(rep)}, expected {sorted(keys)}")
    return {key: mean_and_ci95([rep[key] for rep in replications]) for key in keys}
