"""EMG-8: composed motions as training data (EnergyMoGen Sec. 5.1 "CompML", Sec. 5.5, app. A).

The paper composes 5000 motions from random sets of three STMC texts with EnergyMoGen,
fine-tunes *only the latent diffusion model* on HumanML3D + CompML for 100K iterations with
learning rate 5·10⁻⁵ (pretraining: 300K at 10⁻⁴ then 10⁻⁵) and reports better text-to-motion
on the HumanML3D test set (Table 1). On the stand-in data:

- **composed set** (:func:`compose_set`, a CompML stand-in): each item a random composable
  pair of stand-in concepts (a locomotion/leg concept and an arm concept, all 35 pairs —
  the 10 held-out pairs of ``config.HELD_OUT_PAIRS`` included, as the paper's random
  texts are mostly combinations HumanML3D lacks); one text per concept; composed with SEF
  (Eq. 10, λ = (0.1, 0.7, 0.2), the paper's best) on the pipeline's pretrained N = 5 models;
  decoded to motion and captioned with the generator's joined text ("… while …"). Size:
  5000/14616 of the training clips (CompML per HumanML3D motion; 342 for 1000 clips); one
  caption per composed motion (CompML: one text per motion) against three per real clip, so
  composed rows are ≈ 10 % of the rows, as CompML's 5000 among HumanML3D's 44970 texts.
  Triples are not possible: the stand-in's arm concepts all own an arm, and the only
  body-part-disjoint triple (a leg concept + waving left + waving right) *is* ``wave_both``.
- **fine-tuning** (:func:`finetune_config`): the pretrained denoiser, only it (VAE and text
  encoder frozen), the paper's ratios — steps = 1/3 of pretraining (100K of 300K) and
  lr = ½ of pretraining's (5·10⁻⁵ vs 10⁻⁴); batch, EMA, text dropout as pretraining.
  *augmented*: rows of the training clips + the composed set; *control*: the same steps on
  the training rows alone (so "more training" is not mistaken for "composed data helps").
- **measurements**: text-to-motion on the held-out in-distribution test set
  (``harness.TextToMotionTest``, the HumanML3D-test stand-in): R-precision, FID,
  MM-Dist, Diversity, oracle accuracy; and on the held-out composed texts (the joined texts
  of the held-out pairs, ``data.composition_items``): oracle accuracy and both-present
  rate, R@3 and FID as ``studies.composition_metrics``.

A seed s takes the pretrained models of its own training seed (``pipeline.SeedPipelines``:
VAE and denoiser retrained with ``data_seed + s``, issue #16: "pretraining seeds varied", so
the seeds replicate pretraining too), redraws the composed set (pairs, texts, noise) with
them, seeds fine-tuning (batches, timesteps, noise, text dropout) and the evaluation noise and
captions. The text-to-motion test is the shared-concept test of
``harness.build_shared_concept_test`` (off the ceiling of the random-batch test).

On a data folder (real data, no concept labels) the study is a ``data.NotMeasurable``: the
composed set composes stand-in concept pairs and the rule's test batches clips by concept.
The notebook's other tables and texts (:func:`ceiling_markdown`, :func:`composed_markdown`,
:func:`results_markdown`, :func:`results_text`, :func:`study_text`, :func:`seconds_text`)
take it and say so; the pretrained models' gates and ground truth's R@3 on the folder's test
windows are still measured.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.core.stats import paired_difference
from repro.core.tables import interval_text, markdown_table
from repro.core.training import TrainConfig, torch_threads
from repro.energymogen.config import ARM_CONCEPTS, HELD_OUT_PAIRS, LOWER_CONCEPTS, PipelineConfig
from repro.energymogen.convergence import TrainingRecord, cached_training_record
from repro.energymogen.data import NotMeasurable, composition_items, concept_text
from repro.energymogen.harness import (
    TextToMotionTest,
    generation_metrics,
    ground_truth_r_precision,
)
from repro.energymogen.model_gates import denoiser_gate_values
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    PipelineSource,
    Sampler,
    encode_latents,
    pipeline_for,
)
from repro.energymogen.studies import composition_metrics, oracle_presence
from repro.infra import cache
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.vae import array_fingerprint
from repro.motion.features import FPS
from repro.standin.captions import sample_captions
from repro.standin.concepts import can_be_simultaneous
from repro.standin.generator import ClipSpec

__all__ = [
    "COMPML_FRACTION", "ROWS", "ComposedSet", "Rows", "augmentation_study", "caption_rows",
    "ceiling_markdown", "composable_pairs", "compose_set", "composed_markdown",
    "composed_set_size", "concatenate_rows", "finetune_config", "ground_truth_ceiling",
    "held_out_composed_metrics", "joined_caption", "load_or_finetune",
    "pipeline_finetune_config", "results_markdown", "results_text", "rows_markdown",
    "seconds_text", "study_text",
]

#: CompML motions per HumanML3D motion: 5000 / 14616 (Sec. 5.1; appendix G.1).
COMPML_FRACTION = 5000 / 14616
#: the compared models: the pretrained denoiser, fine-tuned on training data alone (the
#: registered baseline), fine-tuned on training data + the composed set.
ROWS = ("pretrained", "control", "augmented")
_COMPOSE_NOISE = 10 ** 4     # the composed set's noise seed is this + seed (evaluation: seed)


def composable_pairs() -> list[tuple[str, str]]:
    """Every (lower, arm) pair of the pipeline's pool that can be simultaneous (35)."""
    return [(a, b) for a in LOWER_CONCEPTS for b in ARM_CONCEPTS
            if can_be_simultaneous(a, b)]


def composed_set_size(config: PipelineConfig) -> int:
    """round(5000/14616 × training clips): CompML's size relative to HumanML3D's."""
    return max(1, round(COMPML_FRACTION * config.n_train_clips))


def joined_caption(pair: tuple[str, str], frames: int, rng: np.random.Generator) -> str:
    """One caption of ``pair`` as the generator writes simultaneous clips (its templates
    and paraphrases: "a person walks forward while clapping.")."""
    return sample_captions(ClipSpec(tuple(pair), "simultaneous", frames / FPS), rng, count=1)[0]


@dataclass(frozen=True)
class ComposedSet:
    """B composed motions: concepts, per-concept texts (the n SEF conditions), joined texts
    (their captions), features (B, T, 263) and joints (B, T, 22, 3)."""

    concepts: tuple[tuple[str, str], ...]
    concept_texts: tuple[tuple[str, ...], ...]
    texts: tuple[str, ...]
    features: np.ndarray
    joints: np.ndarray

    def __len__(self) -> int:
        return len(self.texts)

    def presence(self) -> np.ndarray:
        """(B, 2) bool: does the oracle find each concept of each item?"""
        return oracle_presence(self.joints, self.concepts)


def compose_set(pipe: EnergyMoGenPipeline, size: int, seed: int,
                lambdas: tuple[float, float, float] = (0.1, 0.7, 0.2)) -> ComposedSet:
    """The composed set for ``seed``: ``size`` random composable pairs, a random paraphrase
    for each concept and a joined caption (``default_rng([seed, 5005])``), SEF with
    ``lambdas`` from noise ``10⁴ + seed``, decoded."""
    rng = np.random.default_rng([seed, 5005])
    pool = composable_pairs()
    pairs = [pool[int(k)] for k in rng.integers(len(pool), size=size)]
    texts = [tuple(concept_text(name, rng) for name in pair) for pair in pairs]
    joined = [joined_caption(pair, pipe.data.frames, rng) for pair in pairs]
    per_concept = tuple(tuple(t[c] for t in texts) for c in range(2))
    latents = pipe.sample(Sampler("sef", lambdas=lambdas), per_concept, joined,
                          _COMPOSE_NOISE + seed, batch=size)
    features = pipe.decode(latents)
    return ComposedSet(tuple(pairs), per_concept, tuple(joined), features,
                       pipe.joints(features))


# ----------------------------------------------------------------------------------------------
# Training rows and fine-tuning
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Rows:
    """Denoiser training rows: scaled latents (M, N, d), text tokens (M, L, D), mask (M, L)."""

    latents: Tensor
    tokens: Tensor
    mask: Tensor

    def __len__(self) -> int:
        return int(self.latents.shape[0])


def caption_rows(pipe: EnergyMoGenPipeline, features: np.ndarray,
                 captions: Sequence[Sequence[str]]) -> Rows:
    """One row per caption of each motion, as ``load_pipeline`` builds the pretraining rows:
    the motion's scaled VAE mean and the frozen encoder's tokens of the caption."""
    if len(captions) != len(features):
        raise ValueError(f"{len(captions)} caption lists for {len(features)} motions")
    latents = (encode_latents(pipe.vae, pipe.data, features, pipe.device)
               * pipe.latent_scale).cpu()
    rows = [(i, c) for i, caps in enumerate(captions) for c in caps]
    tokens, mask = pipe.encode([c for _, c in rows])
    return Rows(latents[[i for i, _ in rows]], tokens.cpu().contiguous(),
                mask.cpu().contiguous())


def concatenate_rows(*parts: Rows) -> Rows:
    """Rows of several sets; text tokens padded (zeros, mask False) to the widest."""
    width = max(p.tokens.shape[1] for p in parts)

    def pad(x: Tensor) -> Tensor:
        return torch.nn.functional.pad(x, (0, 0, 0, width - x.shape[1])) if x.dim() == 3 \
            else torch.nn.functional.pad(x, (0, width - x.shape[1]))

    return Rows(torch.cat([p.latents for p in parts]), torch.cat([pad(p.tokens) for p in parts]),
                torch.cat([pad(p.mask) for p in parts]))


def finetune_config(config: PipelineConfig, seed: int, threads: int | None = 1,
                    pretraining_steps: int | None = None) -> TrainConfig:
    """Fine-tuning as appendix A's ratios (our reading): steps = round(pretraining steps / 3)
    (100K after 300K; ``pretraining_steps`` = the steps the pretrained denoiser used, default
    ``config.denoiser_training.steps``), lr = pretraining lr / 2 (5·10⁻⁵ vs 10⁻⁴); the rest
    (batch, EMA 0.999, 10 % text dropout) as pretraining. ``threads`` only changes speed (not
    in cache keys)."""
    pretraining = config.denoiser_training
    steps = pretraining.steps if pretraining_steps is None else int(pretraining_steps)
    return replace(pretraining, steps=max(1, round(steps / 3)), lr=pretraining.lr / 2,
                   seed=seed, num_threads=threads)


def pipeline_finetune_config(pipe: EnergyMoGenPipeline, seed: int,
                             threads: int | None = 1) -> TrainConfig:
    """:func:`finetune_config` of ``pipe``'s pretrained denoiser: a third of the steps it used
    (its ``training`` record; ``config.denoiser_training.steps`` when it has none)."""
    record = pipe.training.get("denoiser")
    return finetune_config(pipe.config, seed, threads,
                           None if record is None else record.steps)


def load_or_finetune(pipe: EnergyMoGenPipeline, rows: Rows,
                     train_config: TrainConfig) -> tuple[LatentDenoiser, TrainingRecord]:
    """A copy of ``pipe.denoiser`` fine-tuned on ``rows`` (cache kind
    ``emg_finetuned_denoiser``, keyed by the pretrained weights, the rows and the config) and
    its training record (``convergence.cached_training_record`` of that entry); the
    pipeline's denoiser is left untouched."""
    base = pipe.denoiser
    key = {"base": array_fingerprint(*base.state_dict().values()),
           "model": base.config(), "train": train_config.to_config(),
           "data": array_fingerprint(rows.latents, rows.tokens, rows.mask),
           "schedule": "scaled_linear(0.00085, 0.012)", "T": pipe.diffusion.num_timesteps,
           "format": 1}

    def build() -> nn.Module:       # the cached EMA copy comes back with requires_grad off
        return copy.deepcopy(base).requires_grad_(True)

    def train(model: nn.Module) -> tuple[nn.Module, dict]:   # on the pipeline's device (#33)
        return train_latent_denoiser(model, pipe.diffusion, rows.latents, rows.tokens, rows.mask,
                                     replace(train_config, device=str(pipe.device))).for_cache()

    denoiser = cache.load_or_train("emg_finetuned_denoiser", key, build, train,
                                   device=pipe.device).eval()
    return denoiser, cached_training_record("emg_finetuned_denoiser", key, train_config.steps)


# ----------------------------------------------------------------------------------------------
# Measurements
# ----------------------------------------------------------------------------------------------


def held_out_composed_metrics(variant: EnergyMoGenPipeline, seed: int) -> dict[str, float]:
    """Text-to-motion from the joined texts of the held-out pairs (single-text guidance):
    ``studies.composition_metrics`` (oracle accuracy, both-present rate, R@1/R@3
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


# ----------------------------------------------------------------------------------------------
# Notebook 08's tables and texts (a data folder's ``NotMeasurable`` said as such)
# ----------------------------------------------------------------------------------------------

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
