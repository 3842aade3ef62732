"""Measurements of tiny-GMD samples and denoisers: motion quality, Table B.1, diagnostics.

- motion quality: jitter, foot skating, evaluator inputs and FID (``core.metrics``);
- GMD's Table B.1 evaluation (FID, R-precision top-3, Diversity, concept recall) of a
  text-conditioned motion model, read by GMD-B3, GMD-C4's table and the model gates;
- denoiser diagnostics: where a motion model's jitter comes from, without sampling.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor

from repro.core import metrics
from repro.core.diffusion import GaussianDiffusion
from repro.core.stats import t_interval
from repro.core.tables import interval_text, markdown_table
from repro.gmd.guidance import GMD_CFG_SCALE, sample, sample_classifier_free
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import REPRESENTATIONS, FeatureSpace, MotionWindows, short_label
from repro.infra.storage import read_json
from repro.models.evaluator import Evaluator, evaluate_generated
from repro.motion.features import FEATURE_BLOCKS, FPS, features_to_joints
from repro.motion.skeleton import NUM_JOINTS

__all__ = ["ABSOLUTE_ROOT_NAMES", "EvaluationSet", "PAPER_TABLE_B1", "TABLE_METRICS", "by_label",
           "concept_recall", "evaluation_set", "evaluator_inputs", "feature_blocks",
           "foot_skating_of", "generate_for_captions", "ground_truth_row", "high_frequency_share",
           "jitter_of", "measurable", "motion_fid", "noise_floor", "reconstruction",
           "registered_measurements", "sample_quality", "summarise_rows", "table_b1_markdown",
           "table_row", "unguided_sample_quality", "window_concepts", "x0_error_by_block"]

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
    and 2 gated on them; the pilots and ``noise_floor`` still measure them)."""
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



# ------------------------------------------------------------------------------------------------
# GMD's Table B.1 on stand-in data (claim GMD-B3): text-to-motion with either root representation.
#
# The same tiny text-conditioned motion model, trained on relative- and on absolute-root windows,
# generates one motion per test caption; the package's evaluator scores FID, R-precision top-3
# and Diversity against the test windows, and the concept oracles the recall of the captioned
# concepts. GMD-B3 (notebook 02) runs it; GMD-C4's table and the model gates read it too.
# ------------------------------------------------------------------------------------------------

#: Table B.1 of the GMD appendix (HumanML3D): FID ↓, R-precision top-3 ↑, Diversity →.
PAPER_TABLE_B1: dict[str, tuple[float, float, float]] = {
    "Real": (0.002, 0.797, 9.503),
    "MDM (rel)": (0.556, 0.608, 9.446),
    "MDM (abs)": (0.894, 0.638, 8.819),
    "Ours (rel)": (0.305, 0.666, 9.861),
    "Ours (abs)": (0.212, 0.670, 9.440),
    "Ours xproj": (0.235, 0.652, 9.726),
}


@dataclass
class EvaluationSet:
    """The captions a Table B.1 run generates for, and the ground truth they came with.

    ``features`` (n, frames, 263) are the test windows' relative-root features (what the
    evaluator reads); ``captions`` one caption per window, drawn with the set's seed;
    ``truth`` the labelled concepts of each window (:func:`window_concepts`).
    """

    ids: list[str]
    captions: list[str]
    features: np.ndarray
    truth: list[set[str]]

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def lengths(self) -> np.ndarray:
        return np.full(len(self.ids), self.features.shape[1], dtype=np.int64)


def window_concepts(labels: dict, start: int, frames: int) -> set[str]:
    """Concepts labelled in clip frames [start, start + frames): every concept of a single or
    simultaneous clip; for a sequential clip the segments overlapping the window by at least
    half its length."""
    if labels.get("composition") == "sequential":
        found = set()
        for segment in labels["segments"]:
            overlap = min(segment["end"], start + frames) - max(segment["start"], start)
            if overlap >= frames // 2:
                found.add(segment["concept"])
        return found
    return set(labels.get("concepts", []))


def _window_labels(root: Path, window_id: str, frames: int) -> set[str]:
    clip, start = window_id.rsplit(":", 1)
    offset = 0
    if "@" in clip:                       # a sub-range item "<clip>@a-b"
        clip, span = clip.split("@")
        offset = int(span.split("-")[0])
    path = root / "labels" / f"{clip}.json"
    if not path.is_file():
        return set()
    return window_concepts(read_json(path), offset + int(start), frames)


def evaluation_set(test_windows: MotionWindows, n: int, *, seed: int) -> EvaluationSet:
    """n test windows drawn with ``seed`` (in window order), one caption each, as
    relative-root features (absolute-root windows are converted: the same motions)."""
    n = min(n, len(test_windows))
    rng = np.random.default_rng(seed)
    picks = np.sort(rng.choice(len(test_windows), n, replace=False))
    captions = [test_windows.captions[i][rng.integers(len(test_windows.captions[i]))]
                for i in picks]
    with torch.no_grad():
        features = test_windows.space("motion").relative_features(
            test_windows.x[torch.from_numpy(picks)]).numpy()
    ids = [test_windows.ids[i] for i in picks]
    truth = [_window_labels(test_windows.root, i, test_windows.frames) for i in ids]
    return EvaluationSet(ids, captions, features.astype(np.float32), truth)


def generate_for_captions(trained: TrainedGMD, captions: Sequence[str], *, seed: int,
                          guidance_scale: float = GMD_CFG_SCALE,
                          batch_size: int = 128) -> np.ndarray:
    """One sample per caption with classifier-free guidance at ``guidance_scale`` (GMD: 2.5;
    1 = plain conditional sampling; ``guidance.sample_classifier_free``), returned as
    relative-root features (n, frames, 263) (an abs model's samples are converted with
    ``absolute_to_relative_root``).
    Batch k uses the sampling seed 10 000·seed + k, so models sampled with one seed share
    their noise."""
    out = []
    for k, start in enumerate(range(0, len(captions), batch_size)):
        chunk = list(captions[start:start + batch_size])
        x = sample_classifier_free(trained, len(chunk), seed=10_000 * seed + k, text=chunk,
                                   scale=guidance_scale)
        with torch.no_grad():
            out.append(trained.space.relative_features(x).cpu().numpy())
    return np.concatenate(out).astype(np.float32)


def concept_recall(features: np.ndarray, truth: Sequence[set[str]]) -> float:
    """Fraction of (window, labelled concept) pairs the concept oracles find in the joints
    recovered from relative-root ``features`` (n, frames, 263) (``oracles.detect_concepts``)."""
    from repro.standin.oracles import detect_concepts

    joints = features_to_joints(np.asarray(features, dtype=np.float64))
    hits = total = 0
    for clip, concepts in zip(joints, truth, strict=True):
        if not concepts:
            continue
        detected = detect_concepts(clip)
        hits += len(concepts & detected)
        total += len(concepts)
    return hits / total if total else float("nan")


def table_row(evaluator: Evaluator, generated: np.ndarray, evaluation: EvaluationSet, *,
              seed: int) -> dict[str, float]:
    """FID (generated vs the evaluation set's ground truth), R-precision top-3, Diversity
    (``evaluator.evaluate_generated``) and the concept-oracle recall of one generated set."""
    result = evaluate_generated(evaluator, generated, evaluation.lengths, evaluation.captions,
                                evaluation.features, evaluation.lengths, seed=seed)
    return {"fid": result["fid"], "r_precision_top3": result["r_precision_top3"],
            "diversity": result["diversity"],
            "concept_recall": concept_recall(generated, evaluation.truth)}


def ground_truth_row(evaluator: Evaluator, evaluation: EvaluationSet,
                     train_features: np.ndarray, *, seed: int) -> dict[str, float]:
    """The "Real" row: FID of the evaluation set against as many training windows (drawn with
    ``seed``), R-precision top-3 and Diversity of the evaluation set with its own captions,
    and the concept oracles' recall on it (their ceiling on these windows)."""
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(train_features), len(evaluation), replace=False)
    train = np.asarray(train_features)[np.sort(picks)]
    result = evaluate_generated(evaluator, evaluation.features, evaluation.lengths,
                                evaluation.captions, train, evaluation.lengths, seed=seed)
    return {"fid": result["fid"], "r_precision_top3": result["r_precision_top3"],
            "diversity": result["diversity"],
            "concept_recall": concept_recall(evaluation.features, evaluation.truth)}


def summarise_rows(per_seed: Sequence[dict[str, float]]) -> dict[str, dict[str, float] | str]:
    """Per metric: mean and Student-t 95 % interval over seeds (``core.stats.t_interval``);
    :data:`NOT_MEASURABLE` for a metric with no number (concept recall without ``labels/``)."""
    names = per_seed[0].keys()
    columns = {name: [row[name] for row in per_seed] for name in names}
    return {name: t_interval(values).as_dict() if measurable(values) else NOT_MEASURABLE
            for name, values in columns.items()}


TABLE_METRICS = ("fid", "r_precision_top3", "diversity", "concept_recall")


#: concept recall on a folder without the stand-in's ``labels/`` (real HumanML3D): no window
#: has labelled concepts, so :func:`concept_recall` is NaN and the table says this instead
NOT_MEASURABLE = "not measurable on real data"


def measurable(values: float | Sequence[float]) -> bool:
    """Whether a column's values hold a number (concept recall is NaN without labels)."""
    return bool(np.isfinite(np.asarray(values, dtype=np.float64)).any())


def table_b1_markdown(real: dict[str, float], rows: dict[str, list[dict[str, float]]]) -> str:
    """Our Table B.1 (mean ± 95 % t half-width over seeds) with the paper's rows beside it;
    ``rows``: the per-seed rows (:func:`table_row`) of each representation."""
    header = ["row", "FID ↓", "R-precision top-3 ↑", "Diversity →", "concept recall ↑",
              "seeds"]
    body: list[list[object]] = [["Real (stand-in test vs train)"]
                                + [real[m] if measurable(real[m]) else NOT_MEASURABLE
                                   for m in TABLE_METRICS] + ["–"]]
    for rep in REPRESENTATIONS:
        body.append([f"tiny GMD ({short_label(rep)})"]
                    + [interval_text([r[m] for r in rows[rep]], decimals=3)
                       if measurable([r[m] for r in rows[rep]]) else NOT_MEASURABLE
                       for m in TABLE_METRICS] + [len(rows[rep])])
    for name, (fid, r3, div) in PAPER_TABLE_B1.items():
        body.append([f"paper: {name}", fid, r3, div, "–", "–"])
    return markdown_table(header, body)


def by_label(per_representation: dict[str, object]) -> dict[str, object]:
    """The same values keyed by the short labels "rel"/"abs" (the ledger's layout)."""
    return {short_label(rep): value for rep, value in per_representation.items()}


def registered_measurements(real: dict[str, float],
                            rows: dict[str, list[dict[str, float]]]) -> dict[str, object]:
    """GMD-B3's measured values: per-seed FID, R-precision top-3 and Diversity of each
    representation (``fid_rel``, ``fid_abs``, …) and the real windows' Diversity."""
    measured: dict[str, object] = {}
    for metric in ("fid", "r_precision_top3", "diversity"):
        for rep in REPRESENTATIONS:
            measured[f"{metric}_{short_label(rep)}"] = [r[metric] for r in rows[rep]]
    measured["diversity_real"] = real["diversity"]
    return measured



# ------------------------------------------------------------------------------------------------
# Where a motion model's jitter comes from: diagnostics beside the quality gate.
#
# The ``gmd_motion`` gate (``core.gates``, version 3) says whether the denoiser beats the best
# Gaussian denoiser on held-out x̂0 (it reads no skating or jitter of samples, which claims
# compare); these say *where* a model's jitter comes from, without sampling:
#
# * :func:`x0_error_by_block` — the denoiser's RMS error on x0, per feature block, at chosen t,
#   beside the noise √(1 − ᾱ_t) that x_t still holds. An error far above that noise at small t,
#   and no smaller at t = 0 than at T/10, is set by the network, not by the noise in its input.
# * :func:`reconstruction` — x̂0(x_t, t) of real windows: at t = 0 what the sampler's last step
#   returns when everything before it was right, so jitter in it is the denoiser's own (it is
#   not a bound on the samples' values: samples need not be the windows it was given).
# * :func:`high_frequency_share` — the share of the frame-to-frame differences' power near the
#   Nyquist frequency (0.5 cycles/frame, the alternation of even and odd frames), per block.
# * :func:`noise_floor` — the gate's physical measurements of real windows with white noise of
#   σ (model units) added: the per-frame precision a sample needs.
#
# Feature blocks are ``motion.features.FEATURE_BLOCKS``, renamed for GMD's absolute root
# (channel 0 is then the root's heading angle and channels 1:3 its x/z position).
# ------------------------------------------------------------------------------------------------

#: names of the root blocks when the root is absolute (GMD's representation)
ABSOLUTE_ROOT_NAMES = {"root_rot_velocity": "root_angle", "root_linear_velocity": "root_xz"}


def feature_blocks(representation: str) -> dict[str, slice]:
    """``FEATURE_BLOCKS`` with the root blocks named for ``representation``."""
    if representation == "absolute":
        return {ABSOLUTE_ROOT_NAMES.get(name, name): s for name, s in FEATURE_BLOCKS.items()}
    return dict(FEATURE_BLOCKS)


def _timesteps(t: int, batch: int, device: torch.device) -> Tensor:
    return torch.full((batch,), int(t), dtype=torch.long, device=device)


def reconstruction(model: Callable[..., Tensor], diffusion: GaussianDiffusion, x0: Tensor,
                   t: int, *, seed: int = 0) -> Tensor:
    """x̂0(x_t, t) with x_t = √ᾱ_t x0 + √(1 − ᾱ_t) ε (ε drawn with ``seed``), whichever the
    model predicts (``GaussianDiffusion.p_mean_variance``'s x̂0, unclamped)."""
    if not 0 <= t < diffusion.num_timesteps:
        raise ValueError(f"t must be in [0, {diffusion.num_timesteps}), got {t}")
    noise = torch.randn(x0.shape, generator=torch.Generator().manual_seed(seed),
                        dtype=x0.dtype).to(x0.device)
    steps = _timesteps(t, len(x0), x0.device)
    with torch.no_grad():
        x_t = diffusion.q_sample(x0, steps, noise)
        return diffusion.p_mean_variance(model, x_t, steps).pred_x0


def x0_error_by_block(model: Callable[..., Tensor], diffusion: GaussianDiffusion, x0: Tensor,
                      timesteps: Iterable[int], *, representation: str = "absolute",
                      seed: int = 0) -> dict[int, dict[str, float]]:
    """Per t: the RMS of x̂0 − x0 (model units) over each feature block of windows x0
    (B, 263, T), and ``"noise"``: √(1 − ᾱ_t), the noise x_t holds. Seeds differ per t."""
    blocks = feature_blocks(representation)
    out = {}
    for k, t in enumerate(timesteps):
        squared = (reconstruction(model, diffusion, x0, int(t), seed=seed + k) - x0) ** 2
        row = {name: float(squared[:, s].mean().sqrt()) for name, s in blocks.items()}
        row["noise"] = float(np.sqrt(1.0 - diffusion.alphas_cumprod[int(t)]))
        out[int(t)] = row
    return out


def high_frequency_share(x: Tensor, *, above: float = 0.35,
                         representation: str = "absolute") -> dict[str, float]:
    """Per feature block of windows x (B, 263, T): the share of the power of the frame-to-frame
    differences Δx at frequencies ≥ ``above`` cycles per frame (of 0.5). A ramp or a slow
    wave gives about 0; the alternation of even and odd frames gives 1."""
    if not 0.0 < above <= 0.5:
        raise ValueError(f"above must be in (0, 0.5], got {above}")
    steps = torch.diff(x.detach().double(), dim=-1)
    power = torch.fft.rfft(steps, dim=-1).abs() ** 2
    high = torch.fft.rfftfreq(steps.shape[-1]) >= above
    shares = {}
    for name, s in feature_blocks(representation).items():
        total = float(power[:, s].sum())
        shares[name] = float(power[:, s][..., high].sum()) / total if total > 0 else 0.0
    return shares


def noise_floor(space: FeatureSpace, x: Tensor, sigmas: Sequence[float],
                channels: Mapping[str, slice],
                measure: Callable[[Tensor], Mapping[str, float]], *,
                seed: int = 0) -> list[dict[str, Any]]:
    """``measure(joints)`` of windows x (B, 263, T) with white noise of each σ (model units)
    added to each named channel range (e.g. ``{"all": slice(0, 263), "root": slice(0, 4)}``).
    One row per (range, σ), σ = 0 first when given: the data's own value."""
    if space.task != "motion":
        raise ValueError("noise_floor measures joints: it needs the motion task's space")
    generator = torch.Generator().manual_seed(seed)
    rows = []
    for where, s in channels.items():
        for sigma in sigmas:
            noisy = x.clone()
            noisy[:, s] += float(sigma) * torch.randn(noisy[:, s].shape, generator=generator,
                                                      dtype=x.dtype)
            with torch.no_grad():
                values = measure(space.joints(noisy))
            rows.append({"channels": where, "sigma": float(sigma), "windows": len(x),
                         **dict(values)})
    return rows
