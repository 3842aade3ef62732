"""EMG-7 (EnergyMoGen appendix D, Table 8: "For reconstruction, 7 latent vectors achieve the best
results. ... Using 5 latent vectors ... obtains the best text-to-motion generation
performance"): the number N of latent vectors of the motion VAE; the settings are
:class:`LatentCountSettings`. Registered as EMG-7 in ``repro.claims.registry_energymogen``.

The sweep N ∈ ``settings.LATENT_COUNTS`` retrains the VAE and the latent denoiser of the
shared pipeline (``repro.energymogen.pipeline``) with *everything else identical*: the same
data, widths, training plan (with the pipeline's ``TrainingPlan`` every N's VAE trains to its
own plateau under the same step cap), learning rates and schedule (``PipelineConfig`` with
only ``latent_count`` replaced), the same frozen text encoder (the stand-in for CLIP, which
the paper keeps fixed for every N) and the same evaluator (:func:`load_or_train_variant`). A
*training seed* s seeds the VAE (initialisation, batches, reparameterisation noise) and the
denoiser (initialisation, batches, timesteps, noise, text dropout); the data do not change
with s. For N = 5 and s = the pipeline's ``data_seed`` the models *are* the pipeline's
(notebooks 04/05), taken from it, not retrained.

Measured on the held-out **text-to-motion test set** of ``repro.energymogen.harness``
(``TextToMotionTest``, the stand-in for the HumanML3D test set): clips drawn exactly as the
training clips (single concepts and the trained pairs, same probabilities) with random keys
disjoint from the training ones (:func:`latent_count_study`).

- reconstruction (Table 8 top): decode(μ(x)) of every test clip; our reconstruction error is
  the **MPJPE** (:func:`mpjpe`) — mean per-joint position error in metres between the joints
  recovered from the reconstructed and from the true features (global positions, root
  trajectory included, as MLD's reconstruction MPJPE); beside it the MSE of normalised
  features and the Table 8 columns of the reconstructions (FID, R-precision, MM-Dist,
  Diversity);
- generation (Table 8 bottom): one caption per test clip (drawn with the seed), single-text
  classifier-free guidance with the pipeline's scale and DDIM steps, decoded; the Table 8
  columns against the test clips.

Beside the study: the gate records of every N's models (:func:`latent_count_records`), their
training rows (:func:`latent_count_training`), the controls (:func:`latent_count_controls`:
A/A runs, each part's named N against an independently trained copy of itself, with and
without twice the part's δ planted), the claim
(:func:`emg7_result`) and the figures. Our choices are in the docstrings ("our choice").
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from repro.claims.result import ClaimResult, Controls
from repro.core import metrics
from repro.core.tables import interval_text
from repro.core.training import torch_threads
from repro.energymogen import settings as rule_settings
from repro.energymogen.figures import Record
from repro.energymogen.harness import (
    AASlot,
    TextToMotionTest,
    aa_controls,
    copy_seed,
    generation_metrics,
    oracle_accuracy,
)
from repro.energymogen.model_gates import (
    REFERENCE_LATENT_COUNT,
    data_sample_values,
    denoiser_gate_values,
    denoiser_record,
    denoiser_sample_values,
    gate_seed,
    vae_record,
    vae_sample_values,
)
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    retrain_pipeline,
)
from repro.energymogen.settings import (
    LATENT_COUNTS,
    ONE_THREAD,
    QUICK_LATENT_COUNTS,
    STANDARD_LATENT_COUNTS,
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale
from repro.models.evaluator import evaluate_generated
from repro.motion.features import features_to_joints
from repro.motion.plotting import filmstrip
from repro.standin.figures import NOT_MEASURABLE

__all__ = [
    "LatentCountSettings",
    "PAPER_REAL_MOTION",
    "PAPER_TABLE8",
    "TABLE8_COLUMNS",
    "emg7_result",
    "example_reconstructions",
    "latent_count_controls",
    "latent_count_figure",
    "latent_count_records",
    "latent_count_study",
    "latent_count_training",
    "load_or_train_variant",
    "mpjpe",
    "real_motion_metrics",
    "reconstruction_metrics",
    "reconstructions_figure",
    "table8_markdown",
]


@dataclass(frozen=True)
class LatentCountSettings(NotebookSettings):
    """Notebook 07 (EMG-7): the N swept, the training seeds, the size of the held-out
    text-to-motion test set (256 clips: 8 R-precision batches of 32, FID of 32-d embeddings
    from 256 samples; 64 in quick runs), the torch threads and the training plan
    (``TrainingPlan.for_scale``: every N's VAE and denoiser trained to convergence
    at paper, the VAE's cap from the pilot of pilots/pilot_emg_vae.md; fixed steps at standard).
    On a data folder EMG-7 is measured (reconstruction error, and FID of generated motions
    against the folder's test windows); its oracle columns read not measurable on real data."""

    NOTEBOOK: ClassVar[str] = "07_latent_count"
    scale: str
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    plan: TrainingPlan
    counts: tuple[int, ...] = LATENT_COUNTS
    threads: int = ONE_THREAD

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def counts_not_run(self) -> tuple[int, ...]:
        """The N of ``LATENT_COUNTS`` this scale does not sweep (paper only)."""
        return tuple(n for n in LATENT_COUNTS if n not in self.counts)

    @classmethod
    def for_scale(cls, scale: str) -> LatentCountSettings:
        """Standard and paper runs sweep the paper's N ∈ {1, 3, 5, 7}; quick runs N = 5 and 7
        only, the two the rule names (one extra VAE and denoiser per seed: every other N runs
        the same code)."""
        scale = check_scale(scale)
        return cls(scale=scale, pipeline=pipeline_config(scale), seeds=seeds_of("EMG-7", scale),
                   test_clips=rule_settings.text_test_clips(scale),
                   plan=TrainingPlan.for_scale(scale),
                   counts={"quick": QUICK_LATENT_COUNTS, "standard": STANDARD_LATENT_COUNTS,
                           "paper": LATENT_COUNTS}[scale])


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
    training records (``pipeline.TrainingRecord.to_dict``: steps used, cap, converged,
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


def latent_count_records(pipe: EnergyMoGenPipeline, results: Mapping[str, Any],
                         counts: Sequence[int], seeds: Sequence[int], test: TextToMotionTest,
                         *, threads: int | None = 1,
                         reads: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """EMG-7: the ``vae`` and ``latent_denoiser`` records of every (N, training seed) of
    ``latent_count_study``'s ``results``: the VAE's concept preservation as the
    study measured it (its reconstructions' ``oracle_accuracy`` against the real clips'), the
    denoiser's x̂0 error measured here on ``test`` (:func:`denoiser_gate_values`,
    :func:`gate_seed`); the models are reloaded from the cache
    (``load_or_train_variant``). N = :data:`REFERENCE_LATENT_COUNT` is the
    reference arm (its sample gates measured here too), every other N a treatment arm. On a
    data folder the oracles' recall is NaN and the VAE gate reads "not measured"."""
    records = []
    reference = data_sample_values(pipe, test)
    for i, seed in enumerate(seeds):
        real_recall = float(results["real"]["oracle_accuracy"][i])
        for n in counts:
            role = "reference" if n == REFERENCE_LATENT_COUNT else "treatment"
            with torch_threads(threads):     # the study's threads: the same cache entries
                variant = load_or_train_variant(pipe, n, seed, threads=threads)
                fit = denoiser_gate_values(variant, test, gate_seed(variant))
                if role == "reference":
                    fit.update(denoiser_sample_values(variant, test, gate_seed(variant)))
            recall = results["reconstruction"][str(n)]["oracle_accuracy"][i]
            values = {} if np.isnan(recall) else {"concept_preservation": recall}  # NaN: real
            if role == "reference":
                values.update(vae_sample_values(variant, test))
            records.append(vae_record(variant, values,
                                      {**reference, "concept_preservation": real_recall},
                                      role=role, reads=reads, arm=f"N={n}"))
            records.append(denoiser_record(variant, fit, reference=reference, role=role,
                                           reads=reads, arm=f"N={n}"))
    return records


def latent_count_controls(pipe: EnergyMoGenPipeline, test: TextToMotionTest,
                          results: Mapping[str, Any], counts: Sequence[int],
                          seeds: Sequence[int], *, threads: int | None = 1) -> Controls:
    """EMG-7's controls as A/A runs (``harness.aa_controls``). Each part's reference arm is
    the N it names (N = 7 for reconstruction, N = 5 for generation); its null is that N's
    pipeline of train seed s against the same N trained with seed s' = ``copy_seed(seeds,
    s)`` (the run's next seed, cyclic: the standard scale's seeds already train it; one seed:
    s + 1, trained here), in every other N's slot: reconstruction error = MPJPE of decode(μ)
    on the same test clips (deterministic in the models, so a copy the study measured is
    reused), generation FID = the study's measurement with seed s's captions and noise on the
    copy. Positive: the same A/A with twice each part's δ planted on the named N (its error
    or FID × exp(−2δ): every log(other N / named N) up by 2δ)."""
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy: dict[str, Any] = {"reconstruction_error": {"7": []}, "generation_fid": {"5": []}}
    with torch_threads(threads):     # the study's threads: the same cache entries
        for seed, other in copies.items():
            if other in seeds:
                recon = results["reconstruction"]["7"]["mpjpe"][list(seeds).index(other)]
            else:
                variant = load_or_train_variant(pipe, 7, other, threads=threads)
                recon = mpjpe(variant.decode(variant.encode_motion(test.features)),
                              test.features)
            copy["reconstruction_error"]["7"].append(float(recon))
            variant = load_or_train_variant(pipe, REFERENCE_LATENT_COUNT, other, threads=threads)
            copy["generation_fid"]["5"].append(
                float(generation_metrics(variant, test, seed)["fid"]))
    reference = {"reconstruction_error": {str(n): results["reconstruction"][str(n)]["mpjpe"]
                                          for n in counts},
                 "generation_fid": {str(n): results["generation"][str(n)]["fid"]
                                    for n in counts}}
    slots = ([AASlot(("reconstruction_error", str(n)), ("reconstruction_error", "7"))
              for n in counts if n != 7]
             + [AASlot(("generation_fid", str(n)), ("generation_fid", "5"))
                for n in counts if n != REFERENCE_LATENT_COUNT])
    return aa_controls("EMG-7", reference, copy, slots,
                       {"n7_reconstructs_best": [("reconstruction_error", "7")],
                        "n5_generates_best": [("generation_fid", "5")]},
                       copies=copies, what="N = 7's reconstruction / N = 5's generation")


def emg7_result(results: Mapping[str, Any], settings: LatentCountSettings,
                seeds: Sequence[int], *, test_clips: int, threads: int, controls: Controls,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-7 as the ledger records it (appendix D, Table 8: "7 latent vectors achieve the best
    results" for reconstruction, "5 latent vectors ... the best text-to-motion generation"):
    the reconstruction MPJPE and generation FID of every N per seed from
    ``latent_count_study`` (``results``), the Table 8 columns, training records
    and the controls' calibration beside them; ``test_clips`` the test set's size, ``threads`` the
    torch threads used for training."""
    config, plan, counts = settings.pipeline, settings.plan, settings.counts
    recon_error = {str(n): results["reconstruction"][str(n)]["mpjpe"] for n in counts}
    gen_fid = {str(n): results["generation"][str(n)]["fid"] for n in counts}
    notes = (
        "Our choices: the notebooks 04/05 pipeline with only latent_count changed "
        f"({config.n_train_clips} clips of {config.frames} frames; VAE width {config.vae_width}, "
        f"{config.vae_layers}+{config.vae_layers} layers, d={config.latent_dim}, "
        f"{plan.summary()}; denoiser width {config.denoiser_width}, {config.denoiser_layers} "
        f"layers; N swept {list(counts)}"
        + (f" (N = {list(settings.counts_not_run)} not run at the {settings.scale} scale: "
           "standard and paper scales only; 'every other N' is the N swept)"
           if settings.counts_not_run else "")
        + f"; guidance "
        f"{config.guidance_scale}, DDIM {config.ddim_steps}); the frozen text encoder shared by "
        "every N; training seeds vary VAE and denoiser, not the data. Reconstruction error = "
        "MPJPE (m) of decode(mu) "
        f"on {test_clips} held-out in-distribution clips (global joints); FID/R-precision/"
        f"MM-Dist/Diversity with the tiny {config.evaluator.dim}-d evaluator (its own scale). "
        f"{threads} torch thread(s) for training.")
    headline = (f"MPJPE N={'/'.join(str(n) for n in counts)}: "
                + "/".join(f"{np.mean(recon_error[str(n)]):.3f}" for n in counts)
                + " m; generation FID: " + "/".join(f"{np.mean(gen_fid[str(n)]):.3f}"
                                                    for n in counts))
    extra = {"table8": {k: results[k] for k in ("reconstruction", "generation", "real")},
             "paper_table8": PAPER_TABLE8, "training_seconds": results["seconds"],
             "training": results["training"], "plan": dataclasses.asdict(plan),
             "scale": settings.scale, "counts": list(counts),
             "counts_not_run": list(settings.counts_not_run),
             "test_clips": test_clips, "control_calibration": controls.planted}
    return ClaimResult("EMG-7", {"reconstruction_error": recon_error, "generation_fid": gen_fid},
                       seeds=seeds, settings=rule_settings.emg7(settings, test_clips),
                       controls=controls, models=models, figures=figures,
                       headline=headline, notes=notes, extra=extra)


def latent_count_figure(results: Mapping[str, Any], counts: Sequence[int]) -> Figure:
    """EMG-7 (``latent_count_study``): MPJPE, reconstruction and generation FID
    and generation R@3 by N, ours (dots: seeds) and the paper's Table 8 (dashed, right axis)."""

    def dots(ax: Axes, part: str, metric: str) -> None:
        means = [np.mean(results[part][str(n)][metric]) for n in counts]
        ax.plot(counts, means, "-o", color="C0", label="ours")
        for n in counts:
            values = results[part][str(n)][metric]
            ax.plot(np.full(len(values), n), values, ".", color="k", ms=4, alpha=0.6)

    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    dots(axes[0, 0], "reconstruction", "mpjpe")
    axes[0, 0].set_title("reconstruction error (MPJPE, m) — the rule's measurement", fontsize=9)
    for ax, part, metric, title in ((axes[0, 1], "reconstruction", "fid", "reconstruction FID"),
                                    (axes[1, 0], "generation", "fid", "generation FID"),
                                    (axes[1, 1], "generation", "r_precision_top3",
                                     "generation R-precision top-3")):
        dots(ax, part, metric)
        twin = ax.twinx()
        twin.plot(counts, [PAPER_TABLE8[part][str(n)][metric] for n in counts], "--s",
                  color="C1", label="paper (right axis)")
        twin.set_ylabel(f"paper {metric}", color="C1")
        ax.set_title(f"{title}: ours (dots: seeds) and paper (dashed)", fontsize=9)
        handles = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
        ax.legend(handles, [h.get_label() for h in handles], fontsize=7, loc="best")
    for ax in axes.ravel():
        ax.set_xlabel("N latent vectors")
        ax.set_xticks(counts)
    fig.tight_layout()
    return fig


def reconstructions_figure(clip_joints: np.ndarray, caption: str,
                           reconstructions: Sequence[tuple[int, np.ndarray, float]]) -> Figure:
    """One test clip (joints (T, 22, 3)) and its reconstruction by each N: ``reconstructions``
    holds (N, joints, MPJPE in m)."""
    fig, axes = plt.subplots(1 + len(reconstructions), 1,
                             figsize=(10, 2.3 * (1 + len(reconstructions))))
    filmstrip(clip_joints, ax=axes[0], title=f"test clip: {caption}")
    for ax, (n, joints, error) in zip(axes[1:], reconstructions, strict=True):
        filmstrip(joints, ax=ax, title=f"N = {n} reconstruction (MPJPE {error:.3f} m)")
    fig.tight_layout()
    return fig


def latent_count_training(results: Mapping[str, Any], counts: Sequence[int],
                          seeds: Sequence[int]) -> list[tuple[str, Record]]:
    """``latent_count_study``'s training records as (name, record) rows: the
    VAE and the denoiser of every (N, training seed)."""
    rows: list[tuple[str, Record]] = []
    for n in counts:
        for i, seed in enumerate(seeds):
            for part, record in results["training"][str(n)][i].items():
                rows.append((f"{part} N={n} seed {seed}", record))
    return rows
