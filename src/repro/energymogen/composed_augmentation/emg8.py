"""EMG-8 (EnergyMoGen Sec. 5.5: "the model's performance improves with additional training data
from CompML", Table 1): the pretrained denoiser fine-tuned with and without the composed set
(``compml``), measured on the rule's test; the settings are :class:`AugmentationSettings`.
Registered as EMG-8 in ``repro.claims.registry_energymogen``.

- **measurements**: text-to-motion on the held-out in-distribution test set
  (``harness.TextToMotionTest``, the HumanML3D-test stand-in): R-precision, FID,
  MM-Dist, Diversity, oracle accuracy; and on the held-out composed texts (the joined texts
  of the held-out pairs, ``data.composition_items``): oracle accuracy and both-present
  rate, R@3 and FID as ``harness.composition_metrics``.

A seed s takes the pretrained models of its own training seed (``pipeline.SeedPipelines``:
VAE and denoiser retrained with ``data_seed + s``, so the seeds replicate pretraining too),
redraws the composed set (pairs, texts, noise) with them, seeds fine-tuning (batches,
timesteps, noise, text dropout) and the evaluation noise and captions. The text-to-motion test
is the shared-concept test of ``harness.build_shared_concept_test`` (off the ceiling of the
random-batch test).

Beside the study (:func:`augmentation_study`): the gate records of the pretrained and
fine-tuned denoisers (:func:`augmentation_records`), their training rows
(:func:`augmentation_training`), the controls (:func:`augmentation_controls`: A/A runs, the baseline
(control) denoiser of seed s against that of another seed, with and without twice each part's
δ planted on the augmented arm), the claim
(:func:`emg8_result`) and the figures.

On a data folder (real data, no concept labels) the study is a ``data.NotMeasurable``: the
composed set composes stand-in concept pairs and the rule's test batches clips by concept.
The notebook's other tables and texts (:func:`ceiling_markdown`, :func:`composed_markdown`,
:func:`results_markdown`, :func:`results_text`, :func:`study_text`, :func:`seconds_text`)
take it and say so; the pretrained models' gates and ground truth's R@3 on the folder's test
windows are still measured.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core.stats import paired_difference
from repro.core.tables import interval_text, markdown_table
from repro.core.training import TrainConfig, torch_threads
from repro.energymogen import settings as rule_settings
from repro.energymogen.composed_augmentation.compml import (
    ComposedSet,
    caption_rows,
    compose_set,
    concatenate_rows,
    load_or_finetune,
    pipeline_finetune_config,
)
from repro.energymogen.data import NotMeasurable, composition_items
from repro.energymogen.figures import Record
from repro.energymogen.harness import (
    AASlot,
    TextToMotionTest,
    aa_controls,
    composition_metrics,
    copy_seed,
    generation_metrics,
    ground_truth_r_precision,
)
from repro.energymogen.model_gates import denoiser_gate_values, denoiser_record, pipeline_records
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import (
    HELD_OUT_PAIRS,
    ONE_THREAD,
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    composed_set_size,
    finetune_config,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale
from repro.models.latent_denoiser import LatentDenoiser
from repro.motion.plotting import filmstrip, save_figure

__all__ = [
    "AugmentationSettings",
    "HELD_OUT_COLUMNS",
    "ROWS",
    "Study",
    "T2M_COLUMNS",
    "augmentation_controls",
    "augmentation_figure",
    "augmentation_records",
    "augmentation_study",
    "augmentation_training",
    "ceiling_markdown",
    "composed_examples_figure",
    "composed_markdown",
    "emg8_result",
    "ground_truth_ceiling",
    "held_out_composed_metrics",
    "results_markdown",
    "results_text",
    "rows_markdown",
    "save_augmentation_figure",
    "save_composed_examples_figure",
    "seconds_text",
    "study_text",
]


@dataclass(frozen=True)
class AugmentationSettings(NotebookSettings):
    """Notebook 08 (EMG-8): seeds (each with its own pretrained models,
    ``pipeline.SeedPipelines``), the rule's test set — the shared-concept test of
    ``harness.build_shared_concept_test``, 384 clips: one R-precision batch of 32 per concept
    of the pool (12), 64 clips (2 batches) in quick runs —, the random-batch test set on which
    the models' gates are measured (as notebook 07's: 256 clips, 64 quick), torch threads and
    the training plan (notebook 07's); the composed set's size and the fine-tuning follow from
    the pipeline (``composed_set_size``, ``finetune_config``).
    On a data folder EMG-8 is recorded as not measurable on real data (its composed set
    composes stand-in concept pairs, its test batches clips by concept); the pretrained
    models, their gates and ground truth's R@3 on the folder's test windows still run."""

    NOTEBOOK: ClassVar[str] = "08_composed_augmentation"
    scale: str
    pipeline: PipelineConfig
    seeds: int
    test_clips: int
    gate_test_clips: int
    plan: TrainingPlan
    threads: int = ONE_THREAD

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @classmethod
    def for_scale(cls, scale: str) -> AugmentationSettings:
        """The settings of ``scale``, checked here once (its helpers take a valid scale)."""
        scale = check_scale(scale)
        quick = scale == "quick"
        return cls(scale=scale, pipeline=pipeline_config(scale), seeds=seeds_of("EMG-8", scale),
                   test_clips=64 if quick else 384, gate_test_clips=64 if quick else 256,
                   plan=TrainingPlan.for_scale(scale))

    @property
    def composed_set_size(self) -> int:
        """CompML's size relative to HumanML3D's, of the pipeline's training clips."""
        return composed_set_size(self.pipeline)

    def finetune(self, seed: int, pretraining_steps: int | None = None) -> TrainConfig:
        """The fine-tuning configuration of ``seed`` (appendix A's ratios): a third of the
        pretrained denoiser's ``pretraining_steps`` (default the configured steps)."""
        return finetune_config(self.pipeline, seed, self.threads, pretraining_steps)


def augmentation_records(source: PipelineSource, gate_test: TextToMotionTest,
                         results: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int]
                         ) -> dict[str, list[dict[str, Any]]]:
    """EMG-8: per seed s, the records of the pretrained pipeline of s (``pipeline_for``: its
    VAE and denoiser measured here on ``gate_test``, the denoiser with :func:`gate_seed`) and
    of the control and augmented denoisers fine-tuned from it (the x̂0 error
    ``augmentation_study`` measured on its own test at s, its training records). The
    control and augmented denoisers serve their arms (``arm`` "control", "augmented"); the
    VAE every arm decodes with and the pretrained denoiser both arms are fine-tuned from are
    common-mode (``arm`` None).
    Returns ``{"vae": [...], "pretrained": [...], "control": [...], "augmented": [...]}``; for
    a ``NotMeasurable`` study (a data folder: nothing fine-tuned) the pretrained models'
    records only (``control`` and ``augmented`` empty)."""
    out: dict[str, list[dict[str, Any]]] = {"vae": [], "pretrained": [], "control": [],
                                            "augmented": []}
    for i, seed in enumerate(seeds):
        pipe = pipeline_for(source, seed)
        vae, pretrained = pipeline_records(pipe, gate_test, role="reference")
        out["vae"].append(vae)          # every arm decodes with it: common-mode (arm None)
        out["pretrained"].append(pretrained)   # both arms are fine-tuned from it: None
        if isinstance(results, NotMeasurable):
            continue
        for row in ("control", "augmented"):
            out[row].append(denoiser_record(      # fine-tuned: the pretrained architecture
                pipe, {"x0_error_vs_gaussian": results["fitness"][row][i]}, role="treatment",
                name=f"EMG {row} denoiser (fine-tuned from train seed {pipe.train_seed}, "
                     f"seed {seed})",
                denoiser=pipe.denoiser, training=results["training"][row][i], arm=row))
    return out


#: the compared models: the pretrained denoiser, fine-tuned on training data alone (the
#: registered baseline), fine-tuned on training data + the composed set.
ROWS = ("pretrained", "control", "augmented")


def held_out_composed_metrics(variant: EnergyMoGenPipeline, seed: int) -> dict[str, float]:
    """Text-to-motion from the joined texts of the held-out pairs (single-text guidance):
    ``harness.composition_metrics`` (oracle accuracy, both-present rate, R@1/R@3
    in %, FID against the whole held-out pool, ...)."""
    items = composition_items(variant.data, seed, variant.config.items_per_pair)
    features = variant.decode(variant.sample(Sampler("single"), [], items.multi_texts,
                                             seed, batch=len(items)))
    return composition_metrics(variant, features, variant.joints(features), items, seed)


def augmentation_study(source: PipelineSource, test: TextToMotionTest | NotMeasurable,
                       seeds: Sequence[int], *, size: int, threads: int | None = 1,
                       log: Callable[[str], None] | None = None
                       ) -> dict[str, Any] | NotMeasurable:
    """Per seed s, from the pretrained pipeline of s (``pipeline_for(source, s)``; a single
    pipeline is one pretrained model for every seed): compose a set of ``size``, fine-tune
    control and augmented, measure every row of :data:`ROWS` on both tests, all with
    ``threads`` torch threads. Returns ``{"t2m": {row: {metric: per-seed list}},
    "held_out": {row: {...}}, "composed": {metric: per-seed list}, "example": ComposedSet of
    the first seed, "seconds": {...}, "training": {row: per-seed ``TrainingRecord`` of the
    fine-tuned denoisers}, "fitness": {row: per-seed held-out x̂0 error of the fine-tuned
    denoisers over the Gaussian denoiser's on ``test`` (``model_gates.denoiser_gate_values``,
    their ``latent_denoiser`` gate)}, "pretrained_train_seeds": per-seed training seed}``;
    composed-set metrics: the oracles' both-present rate on the set itself, overall and on held-out
    pairs, and their per-concept accuracy. A ``NotMeasurable`` test (a data folder's,
    ``harness.load_or_build_shared_concept_test``) gives a ``NotMeasurable``: nothing is
    composed or fine-tuned."""
    if isinstance(test, NotMeasurable):
        return NotMeasurable(f"{test.reason}; EMG-8 fine-tunes on SEF compositions of stand-in "
                             "concept pairs and tests on batches of clips sharing one concept")
    out: dict[str, Any] = {"t2m": {r: {} for r in ROWS}, "held_out": {r: {} for r in ROWS},
                           "composed": {}, "seconds": {"compose": [], "control": [],
                                                       "augmented": [], "evaluate": []},
                           "training": {"control": [], "augmented": []},
                           "fitness": {"control": [], "augmented": []},
                           "pretrained_train_seeds": []}
    with torch_threads(threads):
        _augment_and_measure(source, test, seeds, size, threads, log, out)
    return out


def _composed_stats(composed: ComposedSet) -> dict[str, float]:
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    presence = composed.presence()
    on_held = np.array([frozenset(c) in held for c in composed.concepts])
    return {"both_present": float(presence.all(1).mean()),
            "oracle_accuracy": float(presence.mean()),
            "held_out_pair_fraction": float(on_held.mean()),
            "both_present_held_out_pairs": float(presence[on_held].all(1).mean())
            if on_held.any() else float("nan")}


def _augment_and_measure(source: PipelineSource, test: TextToMotionTest,
                         seeds: Sequence[int], size: int, threads: int | None,
                         log: Callable[[str], None] | None, out: dict[str, Any]) -> None:
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        out["pretrained_train_seeds"].append(int(pipe.train_seed))
        base_rows = caption_rows(pipe, pipe.data.train_features, pipe.data.train_captions)
        start = time.perf_counter()
        composed = compose_set(pipe, size, seed)
        out.setdefault("example", composed)
        for key, value in _composed_stats(composed).items():
            out["composed"].setdefault(key, []).append(value)
        out["seconds"]["compose"].append(time.perf_counter() - start)
        composed_rows = caption_rows(pipe, composed.features, [(t,) for t in composed.texts])
        config = pipeline_finetune_config(pipe, seed, threads)
        denoisers: dict[str, LatentDenoiser] = {"pretrained": pipe.denoiser}
        for row, rows in (("control", base_rows),
                          ("augmented", concatenate_rows(base_rows, composed_rows))):
            start = time.perf_counter()
            denoisers[row], record = load_or_finetune(pipe, rows, config)
            out["seconds"][row].append(time.perf_counter() - start)
            out["training"][row].append(record)
            out["fitness"][row].append(denoiser_gate_values(
                pipe, test, seed, denoiser=denoisers[row])["x0_error_vs_gaussian"])
        start = time.perf_counter()
        for row in ROWS:
            variant = replace(pipe, denoiser=denoisers[row])
            for part, values in (("t2m", generation_metrics(variant, test, seed)),
                                 ("held_out", held_out_composed_metrics(variant, seed))):
                for metric, value in values.items():
                    out[part][row].setdefault(metric, []).append(float(value))
        out["seconds"]["evaluate"].append(time.perf_counter() - start)
        if log is not None:
            log(f"seed {seed} (pretrained with train seed {pipe.train_seed}): " + ", ".join(
                f"{k} {v[-1]:.1f} s" for k, v in out["seconds"].items()))


def rows_markdown(results: Mapping[str, Mapping[str, Sequence[float]]],
                  columns: Sequence[tuple[str, str]], rows: Sequence[str] = ROWS) -> str:
    """A markdown table: one line per row of ``results`` (row → metric → per-seed list),
    mean ± 95 % half-width over seeds, plus the paired difference augmented − control."""
    lines = ["| model | " + " | ".join(label for _, label in columns) + " |",
             "|" + "---|" * (len(columns) + 1)]
    for row in rows:
        lines.append(f"| {row} | " + " | ".join(
            interval_text(results[row][m]) for m, _ in columns) + " |")
    if "augmented" in results and "control" in results:
        lines.append("| augmented − control (paired) | " + " | ".join(
            interval_text(paired_difference(results["augmented"][m], results["control"][m]))
            for m, _ in columns) + " |")
    return "\n".join(lines)


Study = Mapping[str, Any] | NotMeasurable
#: the text-to-motion columns of the rule's test, and those of the held-out composed texts
T2M_COLUMNS = (("r_precision_top1", "R@1"), ("r_precision_top3", "R@3"), ("fid", "FID"),
               ("mm_dist", "MM-Dist"), ("diversity", "Diversity"),
               ("oracle_accuracy", "oracle acc."))
HELD_OUT_COLUMNS = (("oracle_accuracy", "oracle acc."), ("both_present", "both found"),
                    ("r_precision_top3", "R@3 %"), ("fid", "FID"))


def ground_truth_ceiling(pipe: EnergyMoGenPipeline,
                         tests: Mapping[str, TextToMotionTest | NotMeasurable],
                         seeds: Sequence[int]) -> dict[str, list[float]]:
    """Test name → ground truth's R@3 per seed (``harness.ground_truth_r_precision``) for
    every test of ``tests`` that exists (a ``NotMeasurable`` one is left out)."""
    return {name: [ground_truth_r_precision(pipe, test, s) for s in seeds]
            for name, test in tests.items() if not isinstance(test, NotMeasurable)}


def ceiling_markdown(ceiling: Mapping[str, Sequence[float]],
                     tests: Mapping[str, TextToMotionTest | NotMeasurable]) -> str:
    """The table of :func:`ground_truth_ceiling` (a missing test: its reason)."""
    rows = [[name, len(test), interval_text(ceiling[name])] if name in ceiling
            else [name, "—", test.reason] for name, test in tests.items()]
    return ("**Ground truth's R@3 on each test** (the test clips themselves against their "
            "captions, the pipeline's evaluator; mean ± 95 % half-width over seeds)\n\n"
            + markdown_table(["test", "clips", "R@3 of ground truth"], rows))


def study_text(results: Study, lr: float) -> str:
    """The study's line on its pretrained models and fine-tuning (at ``lr``)."""
    if isinstance(results, NotMeasurable):
        return f"EMG-8: {results.reason}"
    steps = [r.steps for r in results["training"]["control"]]
    return (f"pretrained with training seeds {results['pretrained_train_seeds']}; fine-tuning "
            f"steps per seed {steps} at lr {lr:g}")


def composed_markdown(results: Study) -> str:
    """The composed set itself, measured by the oracles (mean ± 95 % half-width)."""
    if isinstance(results, NotMeasurable):
        return f"**The composed set**: {results.reason}."
    composed = results["composed"]
    labels = {"both_present": "both concepts found (the set's own both-present rate)",
              "oracle_accuracy": "concepts found (per concept)",
              "held_out_pair_fraction": "share of items on held-out pairs",
              "both_present_held_out_pairs": "both found, held-out pairs only"}
    return ("**The composed set itself, measured by the oracles** (mean ± 95 % half-width over "
            "seeds; what the augmented model is fine-tuned on)\n\n"
            + markdown_table(["measure", "value"], [[label, interval_text(composed[key])]
                                                     for key, label in labels.items()]))


def results_markdown(results: Study, test: TextToMotionTest | NotMeasurable) -> str:
    """The two text-to-motion tables: (1) the rule's shared-concept test, (2) the held-out
    composed texts (:func:`rows_markdown`)."""
    if isinstance(results, NotMeasurable):
        return f"**Text-to-motion with and without the composed set**: {results.reason}."
    return (f"**(1) Shared-concept test — the rule's test** ({len(test)} clips)\n\n"
            + rows_markdown(results["t2m"], T2M_COLUMNS)
            + "\n\n**(2) Held-out composed texts (pairs never seen together in training)**"
            "\n\n" + rows_markdown(results["held_out"], HELD_OUT_COLUMNS))


def results_text(results: Study) -> str:
    """Per test and row the per-seed R@3, FID and oracle accuracy."""
    if isinstance(results, NotMeasurable):
        return f"EMG-8: {results.reason}"
    return "\n".join(
        f"{part:8s} {row:10s} R@3 {np.round(values['r_precision_top3'], 3).tolist()} "
        f"FID {np.round(values['fid'], 3).tolist()} oracle "
        f"{np.round(values['oracle_accuracy'], 3).tolist()}"
        for part in ("t2m", "held_out") for row, values in
        ((row, results[part][row]) for row in ROWS))


def seconds_text(results: Study) -> str:
    """Seconds per seed of every stage of the study (none when not measurable)."""
    if isinstance(results, NotMeasurable):
        return "none (EMG-8 not measurable on this data)"
    return str({k: np.round(v, 1).tolist() for k, v in results["seconds"].items()})


def augmentation_controls(source: PipelineSource, test: TextToMotionTest | NotMeasurable,
                          results: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int], *,
                          threads: int | None = 1) -> Controls | None:
    """EMG-8's controls as A/A runs (``harness.aa_controls``). The reference arm is the
    registered baseline, the control denoiser (fine-tuned on the training rows alone); the
    null is seed s's control against the control of seed s' = ``copy_seed(seeds, s)`` (the
    run's next seed, cyclic, whose pretrained pipeline and fine-tuning the study already ran;
    with one seed s + 1, pretrained and fine-tuned here as the study would), the copy in the
    augmented arm's place, measured as the study measures (``harness.generation_metrics`` on
    the shared-concept test with seed s's captions and noise). Positive: the same A/A with
    twice each part's δ planted on the augmented arm (R@3 + 0.02; FID × exp(−2δ)). None for
    a ``NotMeasurable`` study (a data folder: EMG-8 not measurable)."""
    if isinstance(test, NotMeasurable) or isinstance(results, NotMeasurable):
        return None
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy: dict[str, list[float]] = {"r_precision_top3_baseline": [], "fid_baseline": []}
    with torch_threads(threads):
        for seed, other in copies.items():
            pipe = pipeline_for(source, other)
            rows = caption_rows(pipe, pipe.data.train_features, pipe.data.train_captions)
            denoiser, _ = load_or_finetune(pipe, rows,
                                           pipeline_finetune_config(pipe, other, threads))
            values = generation_metrics(replace(pipe, denoiser=denoiser), test, seed)
            copy["r_precision_top3_baseline"].append(float(values["r_precision_top3"]))
            copy["fid_baseline"].append(float(values["fid"]))
    t2m = results["t2m"]
    reference = {"r_precision_top3_augmented": t2m["augmented"]["r_precision_top3"],
                 "r_precision_top3_baseline": t2m["control"]["r_precision_top3"],
                 "fid_augmented": t2m["augmented"]["fid"], "fid_baseline": t2m["control"]["fid"]}
    slots = [AASlot(("r_precision_top3_augmented",), ("r_precision_top3_baseline",)),
             AASlot(("fid_augmented",), ("fid_baseline",))]
    return aa_controls("EMG-8", reference, copy, slots,
                       {"r_precision_improves": [("r_precision_top3_augmented",)],
                        "fid_improves": [("fid_augmented",)]},
                       copies=copies, what="the control (baseline) denoiser")


def _notes(settings: AugmentationSettings, pretrained_train_seeds: Sequence[int],
           finetune_steps: Sequence[int], test_clips: int) -> str:
    """EMG-8's notes: the baseline, the composed set, the fine-tuning, the seeds and the
    test."""
    config, plan, size = settings.pipeline, settings.plan, settings.composed_set_size
    return (
        f"Baseline = control: the same fine-tuning steps ({finetune_steps} per seed) on the "
        "stand-in training data alone (decided before running); the pretrained model is "
        "reported beside. Our choices: "
        f"composed set of {size} SEF compositions (λ = 0.1/0.7/0.2, guidance "
        f"{config.guidance_scale}, DDIM {config.ddim_steps}) of "
        "random composable concept pairs (all 35, held-out pairs included), captioned with the "
        "generator's joined text, one caption each (≈10 % of rows); pairs, not triples (no "
        "body-part-disjoint triple exists in the stand-in); no filtering; fine-tuning only the "
        "latent denoiser for 1/3 of pretraining's steps at 1/2 its lr (appendix A ratios); seeds "
        "vary pretraining (train seeds "
        f"{pretrained_train_seeds}, {plan.summary()}), the composed set, "
        "fine-tuning and evaluation. Test: "
        f"{test_clips} held-out in-distribution clips in batches of 32 sharing one concept, tiny "
        "32-d evaluator; held-out composed texts reported beside.")


def emg8_result(results: Mapping[str, Any] | NotMeasurable, settings: AugmentationSettings,
                seeds: Sequence[int], *, test_clips: int,
                ground_truth_r3: Mapping[str, Sequence[float]], controls: Controls | None,
                models: Sequence[Mapping[str, Any]], figures: Sequence[str | os.PathLike]
                ) -> ClaimResult:
    """EMG-8 as the ledger records it (Sec. 5.5: "the model's performance improves with
    additional training data from CompML"): R@3 and FID of the augmented model against the
    control (the registered baseline) per seed on the shared-concept test, from
    ``augmentation_study`` (``results``), the held-out composed texts, the
    composed set and the training runs beside them; ``test_clips`` the test's size,
    ``ground_truth_r3`` test name → ground truth's R@3 per seed. On a data folder
    (``results`` a ``data.NotMeasurable``) not measurable on real data
    (``claims.result.not_measurable_result``; the models' gates are kept)."""
    if isinstance(results, NotMeasurable):
        return not_measurable_result("EMG-8", results.reason, seeds, models=models,
                                     settings=rule_settings.emg8(settings, test_clips))
    plan, size = settings.plan, settings.composed_set_size
    t2m, held_out = results["t2m"], results["held_out"]
    finetune_steps = [r.steps for r in results["training"]["control"]]
    measured = {"r_precision_top3_augmented": t2m["augmented"]["r_precision_top3"],
                "r_precision_top3_baseline": t2m["control"]["r_precision_top3"],
                "fid_augmented": t2m["augmented"]["fid"], "fid_baseline": t2m["control"]["fid"]}

    def mean(part: str, row: str, metric: str) -> float:
        return float(np.mean(results[part][row][metric]))

    notes = _notes(settings, results["pretrained_train_seeds"], finetune_steps, test_clips)
    headline = ("R@3 augmented/control/pretrained "
                f"{mean('t2m', 'augmented', 'r_precision_top3'):.3f}"
                f"/{mean('t2m', 'control', 'r_precision_top3'):.3f}"
                f"/{mean('t2m', 'pretrained', 'r_precision_top3'):.3f}; FID "
                f"{mean('t2m', 'augmented', 'fid'):.3f}/{mean('t2m', 'control', 'fid'):.3f}/"
                f"{mean('t2m', 'pretrained', 'fid'):.3f}; held-out composed texts both found "
                f"{mean('held_out', 'augmented', 'both_present'):.2f}/"
                f"{mean('held_out', 'control', 'both_present'):.2f}/"
                f"{mean('held_out', 'pretrained', 'both_present'):.2f}")
    extra = {"t2m": t2m, "held_out_composed_texts": held_out, "composed_set": results["composed"],
             "composed_set_size": size, "finetune_steps": finetune_steps,
             "finetune_lr": settings.finetune(seeds[0]).lr, "seconds": results["seconds"],
             "test_clips": test_clips, "test": "shared-concept batches of 32",
             "ground_truth_r_precision_top3": ground_truth_r3,
             "pretrained_train_seeds": results["pretrained_train_seeds"],
             "training": {row: [r.to_dict() for r in results["training"][row]]
                          for row in ("control", "augmented")},
             "plan": dataclasses.asdict(plan), "control_calibration": controls.planted}
    return ClaimResult("EMG-8", measured, seeds=seeds,
                       settings=rule_settings.emg8(settings, test_clips), controls=controls,
                       models=models,
                       figures=figures, headline=headline, notes=notes, extra=extra)


def save_composed_examples_figure(results: Mapping[str, Any] | NotMeasurable,
                                  figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 08's :func:`composed_examples_figure` of the study's example set (the first
    seed's): its first composition on a held-out pair and its first on a trained pair, saved
    under ``figure_path(name)`` (its path in a list); none when not measurable."""
    if isinstance(results, NotMeasurable):
        return []
    example, held = results["example"], {frozenset(p) for p in HELD_OUT_PAIRS}
    picks = [next(i for i, c in enumerate(example.concepts) if frozenset(c) in held),
             next(i for i, c in enumerate(example.concepts) if frozenset(c) not in held)]
    return [save_figure(composed_examples_figure(example, picks),
                        figure_path("emg8_composed_examples.png"))]


def save_augmentation_figure(results: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int],
                             figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 08's :func:`augmentation_figure` saved under ``figure_path(name)`` (its path
    in a list); none when not measurable (a data folder)."""
    if isinstance(results, NotMeasurable):
        return []
    return [save_figure(augmentation_figure(results, seeds),
                        figure_path("emg8_composed_augmentation.png"))]


def composed_examples_figure(example: ComposedSet, picks: Sequence[int]) -> Figure:
    """Composed motions ``picks`` of the set, titled with their text, kind of pair and what
    the oracles find."""
    presence = example.presence()
    held = {frozenset(p) for p in HELD_OUT_PAIRS}
    fig, axes = plt.subplots(len(picks), 1, figsize=(10, 2.4 * len(picks)), squeeze=False)
    for ax, i in zip(axes[:, 0], picks, strict=True):
        found = ", ".join(f"{c} {'✓' if p else '✗'}"
                          for c, p in zip(example.concepts[i], presence[i], strict=True))
        kind = "held-out pair" if frozenset(example.concepts[i]) in held else "trained pair"
        filmstrip(example.joints[i], ax=ax, title=f"composed ({kind}): “{example.texts[i]}” — "
                  f"oracle: {found}")
    fig.tight_layout()
    return fig


def augmentation_figure(results: Mapping[str, Any], seeds: Sequence[int]) -> Figure:
    """EMG-8 (``augmentation_study``): R@3 and FID on the in-distribution test
    and both-found on the held-out composed texts, per row, one line per seed (paired)."""
    panels = [("t2m", "r_precision_top3", "in-distribution test: R@3 (↑)"),
              ("t2m", "fid", "in-distribution test: FID (↓)"),
              ("held_out", "both_present", "held-out composed texts: both concepts found (↑)")]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    x = np.arange(len(ROWS))
    for ax, (part, metric, title) in zip(axes, panels, strict=True):
        values = np.array([results[part][row][metric] for row in ROWS])    # (rows, seeds)
        ax.bar(x, values.mean(1), color=["0.7", "C0", "C2"], alpha=0.7)
        for k in range(len(seeds)):
            ax.plot(x, values[:, k], "k.-", lw=0.8, ms=5, alpha=0.6,
                    label="one seed (paired)" if k == 0 else None)
        ax.set_xticks(x, ROWS)
        ax.set_title(title, fontsize=9)
    axes[0].legend(fontsize=7)
    fig.suptitle("EMG-8: pretrained vs fine-tuned on stand-in data alone (control, the "
                 "baseline) vs with the composed set (augmented)", fontsize=10)
    fig.tight_layout()
    return fig


def augmentation_training(source: PipelineSource, results: Mapping[str, Any] | NotMeasurable,
                          seeds: Sequence[int]) -> list[tuple[str, Record]]:
    """Notebook 08's training records as (name, record) rows: per seed the pretrained VAE and
    denoiser of ``pipeline_for(source, seed)``, then the control and augmented fine-tuning
    runs of ``augmentation_study`` (none when it is not measurable)."""
    rows: list[tuple[str, Record]] = []
    for i, s in enumerate(seeds):
        seed_pipe = pipeline_for(source, s)
        rows += [(f"vae train seed {seed_pipe.train_seed}", seed_pipe.training["vae"]),
                 (f"denoiser train seed {seed_pipe.train_seed}", seed_pipe.training["denoiser"])]
        if not isinstance(results, NotMeasurable):
            rows += [(f"{row} fine-tuning seed {s}", results["training"][row][i])
                     for row in ("control", "augmented")]
    return rows
