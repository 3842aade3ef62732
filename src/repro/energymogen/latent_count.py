"""EMG-7: the number N of latent vectors of the motion VAE (EnergyMoGen appendix D, Table 8).

The sweep N ∈ {1, 3, 5, 7} retrains the VAE and the latent denoiser of the shared pipeline
(``repro.energymogen``) with *everything else identical*: the same data, widths, training plan
(with the pipeline's ``convergence.TrainingPlan`` every N trains to its own plateau under the
same step cap, issue #16: "every N's VAE trained to its gate"), learning rates and schedule
(``PipelineConfig`` with only ``latent_count`` replaced), the same
frozen text encoder (the stand-in for CLIP, which the paper keeps fixed for every N) and the
same evaluator. A *training seed* s seeds the VAE (initialisation, batches, reparameterisation
noise) and the denoiser (initialisation, batches, timesteps, noise, text dropout); the data do
not change with s. For N = 5 and s = the pipeline's ``data_seed`` the models *are* the
pipeline's (notebooks 04/05), taken from it, not retrained.

Measured on the held-out **text-to-motion test set** of ``repro.energymogen.harness``
(``TextToMotionTest``, the stand-in for the HumanML3D test set): clips drawn exactly as the
training clips (single concepts and the trained pairs, same probabilities) with random keys
disjoint from the training ones.

- reconstruction (Table 8 top): decode(μ(x)) of every test clip; our reconstruction error is
  the **MPJPE** — mean per-joint position error in metres between the joints recovered from
  the reconstructed and from the true features (global positions, root trajectory included,
  as MLD's reconstruction MPJPE); beside it the MSE of normalised features and the Table 8
  columns of the reconstructions (FID, R-precision, MM-Dist, Diversity);
- generation (Table 8 bottom): one caption per test clip (drawn with the seed), single-text
  classifier-free guidance with the pipeline's scale and DDIM steps, decoded; the Table 8
  columns against the test clips.

Our choices are in the docstrings ("our choice").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import torch

from repro.core import metrics
from repro.core.tables import interval_text
from repro.core.training import torch_threads
from repro.energymogen.config import PipelineConfig
from repro.energymogen.harness import TextToMotionTest, generation_metrics, oracle_accuracy
from repro.energymogen.pipeline import EnergyMoGenPipeline, retrain_pipeline
from repro.models.evaluator import evaluate_generated
from repro.motion.features import features_to_joints
from repro.standin.figures import NOT_MEASURABLE

__all__ = [
    "LATENT_COUNTS", "PAPER_REAL_MOTION", "PAPER_TABLE8", "TABLE8_COLUMNS",
    "example_reconstructions", "latent_count_study", "load_or_train_variant", "mpjpe",
    "real_motion_metrics", "reconstruction_metrics", "table8_markdown",
]

LATENT_COUNTS = (1, 3, 5, 7)
#: Table 8 columns: (key, label).
TABLE8_COLUMNS: tuple[tuple[str, str], ...] = (
    ("r_precision_top1", "Top-1"), ("r_precision_top2", "Top-2"), ("r_precision_top3", "Top-3"),
    ("fid", "FID"), ("mm_dist", "MM-Dist"), ("diversity", "Diversity"))
_T8_RECON = ((0.493, 0.681, 0.787, 0.170, 3.160, 9.589), (0.501, 0.696, 0.792, 0.117, 3.037, 9.621),
             (0.508, 0.700, 0.795, 0.080, 3.004, 9.620), (0.513, 0.704, 0.797, 0.022, 2.984, 9.603))
_T8_GEN = ((0.498, 0.686, 0.791, 0.424, 3.085, 9.705), (0.523, 0.712, 0.814, 0.418, 2.946, 9.443),
           (0.523, 0.715, 0.815, 0.188, 2.915, 9.488), (0.514, 0.713, 0.813, 0.291, 2.938, 9.456))
#: Table 8 of the paper (HumanML3D test set): part → str(N) → column → value.
PAPER_TABLE8: dict[str, dict[str, dict[str, float]]] = {
    part: {str(n): dict(zip((k for k, _ in TABLE8_COLUMNS), row, strict=True))
           for n, row in zip(LATENT_COUNTS, rows, strict=True)}
    for part, rows in (("reconstruction", _T8_RECON), ("generation", _T8_GEN))}
#: the paper's "Real motion" row on the HumanML3D test set (Table 4, the same test set).
PAPER_REAL_MOTION = dict(zip((k for k, _ in TABLE8_COLUMNS),
                             (0.511, 0.703, 0.797, 0.002, 2.974, 9.503), strict=True))


# ----------------------------------------------------------------------------------------------
# Models with N latent vectors
# ----------------------------------------------------------------------------------------------


def load_or_train_variant(pipe: EnergyMoGenPipeline, latent_count: int, seed: int, *,
                          threads: int | None = 1,
                          log: Callable[[str], None] | None = None) -> EnergyMoGenPipeline:
    """The pipeline with a VAE of ``latent_count`` latent vectors and its latent denoiser,
    trained with training seed ``seed`` (cached by full configuration), sharing ``pipe``'s
    data, frozen text encoder, vocabulary, diffusion and evaluator.

    The steps are ``pipeline.load_pipeline``'s (``pipeline.retrain_pipeline``:
    ``train_vae_stage``, ``train_denoiser_stage``) with training seed ``seed``: VAE on the
    normalised training features; latent scale 1/std of the training means; denoiser rows =
    every caption of every training clip, text tokens from the frozen encoder, 10 % text
    dropout, EMA 0.999. For (N, seed) = (pipe's N, pipe's training seed) this is ``pipe``
    itself; for N = 5 the variant of seed s is the model of ``load_pipeline(config,
    train_seed=s)`` (the per-seed models of notebooks 04/05, the same cache entries).
    ``threads`` only changes speed (not in the cache keys); our choice is 1: at widths of 64
    a second thread gains little and, on shared cores, costs a lot.
    """
    config = replace(pipe.config, latent_count=int(latent_count))
    if config == pipe.config and seed == pipe.train_seed:
        return pipe
    return _train_variant(pipe, config, seed, threads, log)


def _train_variant(pipe: EnergyMoGenPipeline, config: PipelineConfig, seed: int,
                   threads: int | None, log: Callable[[str], None] | None
                   ) -> EnergyMoGenPipeline:
    """:func:`load_or_train_variant` without the shortcut: ``pipeline.retrain_pipeline``
    (``train_vae_stage`` and ``train_denoiser_stage`` with training seed ``seed``; tests check
    that it reproduces the pipeline's own models, i.e. hits the same cache entries)."""
    variant = retrain_pipeline(pipe, seed, config=config, threads=threads)
    if log is not None:
        log(f"N={config.latent_count} seed {seed}: VAE {variant.timings['vae']:.1f} s, "
            f"denoiser {variant.timings['denoiser']:.1f} s")
    return variant


# ----------------------------------------------------------------------------------------------
# Measurements
# ----------------------------------------------------------------------------------------------


def mpjpe(features_a: np.ndarray, features_b: np.ndarray) -> float:
    """Mean per-joint position error (m) between the joints recovered from two feature
    arrays (..., T, 263) (``features_to_joints``: global positions, root path included)."""
    with torch.no_grad():
        a = features_to_joints(torch.from_numpy(np.asarray(features_a, np.float32)))
        b = features_to_joints(torch.from_numpy(np.asarray(features_b, np.float32)))
    return float((a - b).norm(dim=-1).mean())


def reconstruction_metrics(variant: EnergyMoGenPipeline, test: TextToMotionTest,
                           seed: int) -> dict[str, float]:
    """Reconstructions decode(μ(x)) of the test clips: MPJPE (m), MSE of normalised features,
    oracle accuracy (as ``harness.generation_metrics``) and the Table 8 columns
    (``evaluator.evaluate_generated``, captions drawn with ``seed``)."""
    recon = variant.decode(variant.encode_motion(test.features))
    normalised = variant.data.normalise(recon) - variant.data.normalise(test.features)
    out = evaluate_generated(variant.evaluator, recon, test.lengths, test.texts(seed),
                             test.features, test.lengths, seed=seed)
    out.update(mpjpe=mpjpe(recon, test.features), feature_mse=float(np.mean(normalised ** 2)),
               oracle_accuracy=oracle_accuracy(variant.joints(recon), test.concepts))
    return out


def real_motion_metrics(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                        seed: int) -> dict[str, float]:
    """The "Real motion" row: the test clips with their captions; FID of as many *training*
    clips against the test clips (the finite-sample floor of FID, our choice)."""
    count = min(len(test), len(pipe.data.train_features))
    out = evaluate_generated(pipe.evaluator, test.features, test.lengths, test.texts(seed),
                             test.features, test.lengths, seed=seed)
    train = pipe.evaluator.embed_motions(pipe.data.train_features[:count],
                                         np.full(count, pipe.data.frames))
    out["fid"] = metrics.fid(train, pipe.evaluator.embed_motions(test.features, test.lengths))
    out["oracle_accuracy"] = oracle_accuracy(pipe.joints(test.features), test.concepts)
    return out


def example_reconstructions(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                            counts: Sequence[int], seed: int, *, threads: int | None = 1
                            ) -> tuple[int, list[tuple[int, np.ndarray, float]]]:
    """The first two-concept clip of ``test`` (a data folder's test set, without concepts: its
    first clip) reconstructed by the variant of every N in ``counts`` with training seed
    ``seed`` (:func:`load_or_train_variant`, cached models): (the clip's index, [(N,
    reconstructed joints (T, 22, 3), MPJPE in m)])."""
    index = next((i for i, c in enumerate(test.concepts) if len(c) == 2), 0)
    clip = test.features[index:index + 1]
    out = []
    with torch_threads(threads):
        for n in counts:
            variant = load_or_train_variant(pipe, n, seed, threads=threads)
            recon = variant.decode(variant.encode_motion(clip))
            out.append((int(n), variant.joints(recon)[0], mpjpe(recon, clip)))
    return index, out


def latent_count_study(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                       counts: Sequence[int], seeds: Sequence[int], *, threads: int | None = 1,
                       log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Every (N, training seed): train or load the variant, measure reconstruction and
    generation, all with ``threads`` torch threads (``core.training.torch_threads``). Returns
    ``{"reconstruction": {str(N): {metric: per-seed list}},
    "generation": {...}, "real": {metric: per-seed list}, "seconds": {str(N): per-seed
    stage seconds (0 for ``pipe`` itself)}, "training": {str(N): per-seed {"vae", "denoiser"}
    training records (``convergence.TrainingRecord.to_dict``: steps used, cap, converged,
    validation curve)}}``."""
    out: dict[str, Any] = {"reconstruction": {}, "generation": {}, "real": {}, "seconds": {},
                           "training": {}}
    for n in counts:
        for part in ("reconstruction", "generation"):
            out[part][str(n)] = {}
        out["seconds"][str(n)] = []
        out["training"][str(n)] = []
    with torch_threads(threads):
        _measure_counts(pipe, test, counts, seeds, out, threads, log)
    return out


def _measure_counts(pipe: EnergyMoGenPipeline, test: TextToMotionTest, counts: Sequence[int],
                    seeds: Sequence[int], out: dict[str, Any], threads: int | None,
                    log: Callable[[str], None] | None) -> None:
    for seed in seeds:
        for n in counts:
            variant = load_or_train_variant(pipe, n, seed, threads=threads, log=log)
            out["seconds"][str(n)].append(sum(variant.timings.values())
                                          if variant is not pipe else 0.0)
            out["training"][str(n)].append({part: record.to_dict() for part, record
                                            in variant.training.items()})
            for part, measure in (("reconstruction", reconstruction_metrics),
                                  ("generation", generation_metrics)):
                for metric, value in measure(variant, test, seed).items():
                    out[part][str(n)].setdefault(metric, []).append(float(value))
        for metric, value in real_motion_metrics(pipe, test, seed).items():
            out["real"].setdefault(metric, []).append(float(value))


def table8_markdown(results: Mapping[str, Any], counts: Sequence[int] = LATENT_COUNTS,
                    extra: Sequence[tuple[str, str]] = (("mpjpe", "MPJPE m"),)) -> str:
    """Table 8's layout: reconstruction then generation rows by N, ours (mean ± 95 %
    half-width over seeds) [paper]; a real-motion row; ``extra`` columns (ours only). A NaN
    value (the oracles' on a data folder) reads "not measurable on real data"."""
    columns = list(TABLE8_COLUMNS) + list(extra)
    head = "| | N | " + " | ".join(label for _, label in columns) + " |"
    lines = [head, "|" + "---|" * (len(columns) + 2)]

    def cell(values: Mapping[str, Sequence[float]], metric: str,
             paper: Mapping[str, float] | None) -> str:
        nan = metric in values and any(isinstance(v, float) and np.isnan(v)
                                       for v in np.atleast_1d(values[metric]).tolist())
        ours = ("—" if metric not in values else NOT_MEASURABLE if nan
                else interval_text(values[metric]))
        if paper is None or metric not in paper:
            return ours
        return f"{ours} [{paper[metric]}]"

    for part in ("reconstruction", "generation"):
        for n in counts:
            values = results[part][str(n)]
            paper = PAPER_TABLE8[part].get(str(n))
            lines.append(f"| {part} | {n} | " + " | ".join(
                cell(values, m, paper) for m, _ in columns) + " |")
    lines.append("| real motion | — | " + " | ".join(
        cell(results["real"], m, PAPER_REAL_MOTION) if m != "mpjpe" else "—"
        for m, _ in columns) + " |")
    return "\n".join(lines)
