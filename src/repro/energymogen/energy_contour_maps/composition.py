"""The composition study that EMG-2 (Sec. 3.2 ❶ Eq. 7–8: latent-aware conjunction and
negation) and EMG-3 (❷ Eq. 9: semantic-aware) are both decided from: one set of samples per
seed, oracle-measured (:func:`composition_study`), with the baselines the two claims share;
their controls from one A/A copy per seed (:func:`composition_controls`: the baselines sampled
from an independently trained copy, :func:`composition_reference_rates`); the guidance-scale
check beside them (paper scale only, not recorded): :func:`guidance_scale_check`; what both
results say beside their own rates (:func:`composition_headline`, :func:`composition_notes`,
:func:`composition_extra`), the notebook's tables and the figures of both. Each claim's result:
``emg2.emg2_result`` (the latent arm) and ``emg3.emg3_result`` (the semantic arm).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from repro.claims.registry import get_claim
from repro.claims.result import Controls
from repro.core.tables import interval_text, markdown_table
from repro.energymogen.data import (
    NotMeasurable,
    composition_items,
    negation_items,
    not_measurable_reason,
)
from repro.energymogen.energy_contour_maps.notebook_settings import EnergyViewSettings
from repro.energymogen.harness import (
    AASlot,
    aa_controls,
    copy_seed,
    oracle_presence,
    pair_index,
    per_pair_mean,
)
from repro.energymogen.pipeline import EnergyMoGenPipeline, PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import HELD_OUT_PAIRS, NEGATION_CASES
from repro.motion.plotting import filmstrip, save_figure

__all__ = ["by_pair_markdown", "composition_controls", "composition_examples_figure",
           "composition_extra", "composition_headline", "composition_notes",
           "composition_oracle_figure", "composition_reference_rates", "composition_study",
           "composition_study_text", "guidance_scale_check", "save_composition_figures"]


def _seed_presence(pipe: EnergyMoGenPipeline, seed: int, per_case: int,
                   examples: dict[str, np.ndarray] | None) -> dict[str, Any]:
    """One seed of :func:`composition_study` on its pipeline ``pipe``: each sampler's oracle
    readings (samples × concepts, boolean) on the composition items of ``seed`` (conjunction)
    and ``per_case`` items per negation case, the ground truth's, the items' pair index and the
    best single concept per pair; each sampler's first motion kept in ``examples`` (when
    given)."""
    s = pipe.config.guidance_scale
    items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
    c1, c2 = items.concept_texts
    pairs = pair_index(items)

    def presence(sampler: Sampler, concept_texts: Sequence[Sequence[str]],
                 multi: Sequence[str] | None, concepts: Sequence[Sequence[str]],
                 batch: int, tag: str) -> np.ndarray:
        joints = pipe.joints(pipe.decode(pipe.sample(sampler, concept_texts, multi, seed,
                                                     batch=batch)))
        if examples is not None:
            examples[tag] = joints[0]
        return oracle_presence(joints, concepts)

    b = len(items)
    single1 = presence(Sampler("single"), [], c1, items.concepts, b, "concept 1")
    single2 = presence(Sampler("single"), [], c2, items.concepts, b, "concept 2")
    uncond = presence(Sampler("unconditional"), [], None, items.concepts, b, "∅")
    multi = presence(Sampler("single"), [], items.multi_texts, items.concepts, b, "multi")
    conj = {"latent": presence(Sampler("latent"), [c1, c2], None, items.concepts, b,
                               "latent conjunction"),
            "semantic": presence(Sampler("semantic"), [c1, c2], None, items.concepts, b,
                                 "semantic conjunction")}
    best_pairs = np.maximum(per_pair_mean(single1.all(1), pairs),
                            per_pair_mean(single2.all(1), pairs))
    neg = negation_items(seed, per_case)
    neg_concepts = list(zip(neg.kept, neg.negated, strict=True))
    nb = len(neg)
    base = presence(Sampler("single"), [], neg.pair_texts, neg_concepts, nb, "c_i")
    negs = {"latent": presence(Sampler("latent", weights=(s, -s)),
                               [neg.pair_texts, neg.negated_texts], None, neg_concepts, nb,
                               "latent negation"),
            "semantic": presence(Sampler("semantic", semantic_weights=(1.0, -0.5)),
                                 [neg.pair_texts, neg.negated_texts], None, neg_concepts,
                                 nb, "semantic negation")}
    return {"single1": single1, "single2": single2, "uncond": uncond, "multi": multi,
            "conj": conj, "best_pairs": best_pairs, "base": base, "negs": negs,
            "gt": oracle_presence(items.gt_joints, items.concepts), "pairs": pairs}


def composition_study(source: PipelineSource, seeds: Sequence[int], *, per_case: int,
                      log: Callable[[str], None] | None = None
                      ) -> dict[str, Any] | NotMeasurable:
    """EMG-2 (latent-aware, Eq. 7/8) and EMG-3 (semantic-aware, Eq. 9), oracle-measured.

    Seed s uses the model ``pipeline_for(source, s)`` (one pipeline for every seed, or one
    trained model per seed: :class:`SeedPipelines`). Per seed, on the composition items
    (held-out pairs):
    conjunction = Eq. 7 with w_i = s (latent) / Eq. 9 with w^s = (1, 1) guided with s
    (semantic); baselines: each concept's text alone (guided with s), the unconditional
    model, and the joined single text. "best single concept" is, per held-out pair, the better
    of the two single-concept generations' both-present rates, averaged over pairs.
    Negation on :data:`NEGATION_CASES` (``per_case`` items each): Eq. 8 with w = s, i.e.
    ε(∅) + s(ε(c_i) − ε(c_j)) (latent), Eq. 9 with w^s = (1, −0.5), i.e. ẑ' = 2z'_i − z'_j,
    guided with s (semantic; our choice of weights); baseline: c_i alone (guided with s).

    Returns ``{"latent": measured, "semantic": measured, "extra": {...}, "examples": {...}}``
    where ``measured`` has the six registry names of EMG-2/3 as per-seed lists; on a data
    folder (no concepts to compose, no oracle labels) a ``data.NotMeasurable``.
    """
    if not pipeline_for(source, seeds[0]).data.labelled:
        return NotMeasurable(not_measurable_reason(pipeline_for(source, seeds[0]).data))
    names = ("conjunction_both_present", "best_single_concept_both_present",
             "negation_negated_present", "baseline_negated_present", "negation_kept_present",
             "baseline_kept_present")
    measured: dict[str, dict[str, list[float]]] = {m: {n: [] for n in names}
                                                  for m in ("latent", "semantic")}
    extra: dict[str, Any] = {k: [] for k in (
        "unconditional_both_present", "multi_text_both_present", "ground_truth_both_present",
        "single_concept_1_present", "single_concept_2_present")}
    extra["by_pair"] = {m: {"/".join(p): [] for p in HELD_OUT_PAIRS}
                        for m in ("latent", "semantic", "best_single", "multi_text")}
    # which concept a conjunction keeps: items list (lower, arm) in that order
    extra["conjunction_concept_present"] = {m: {"lower": [], "arm": []}
                                            for m in ("latent", "semantic", "multi_text")}
    examples: dict[str, np.ndarray] = {}
    for index, seed in enumerate(seeds):
        start = time.perf_counter()
        pipe = pipeline_for(source, seed)
        read = _seed_presence(pipe, seed, per_case, examples if index == 0 else None)
        conj, negs, base, multi = read["conj"], read["negs"], read["base"], read["multi"]
        single1, single2, uncond, gt = read["single1"], read["single2"], read["uncond"], read["gt"]
        best_pairs, pairs = read["best_pairs"], read["pairs"]
        for mode in ("latent", "semantic"):
            m = measured[mode]
            m["conjunction_both_present"].append(float(conj[mode].all(1).mean()))
            m["best_single_concept_both_present"].append(float(best_pairs.mean()))
            m["negation_negated_present"].append(float(negs[mode][:, 1].mean()))
            m["baseline_negated_present"].append(float(base[:, 1].mean()))
            m["negation_kept_present"].append(float(negs[mode][:, 0].mean()))
            m["baseline_kept_present"].append(float(base[:, 0].mean()))
        extra["unconditional_both_present"].append(float(uncond.all(1).mean()))
        extra["multi_text_both_present"].append(float(multi.all(1).mean()))
        extra["ground_truth_both_present"].append(float(gt.all(1).mean()))
        extra["single_concept_1_present"].append(float(single1[:, 0].mean()))
        extra["single_concept_2_present"].append(float(single2[:, 1].mean()))
        for mode, found in (("latent", conj["latent"]), ("semantic", conj["semantic"]),
                            ("multi_text", multi)):
            extra["conjunction_concept_present"][mode]["lower"].append(float(found[:, 0].mean()))
            extra["conjunction_concept_present"][mode]["arm"].append(float(found[:, 1].mean()))
        per_pair = {"latent": per_pair_mean(conj["latent"].all(1), pairs),
                    "semantic": per_pair_mean(conj["semantic"].all(1), pairs),
                    "best_single": best_pairs,
                    "multi_text": per_pair_mean(multi.all(1), pairs)}
        for mode, values in per_pair.items():
            for p, value in zip(np.unique(pairs), values, strict=True):
                extra["by_pair"][mode]["/".join(HELD_OUT_PAIRS[p])].append(float(value))
        if log is not None:
            log(f"seed {seed}: {time.perf_counter() - start:.1f} s")
    return {"latent": measured["latent"], "semantic": measured["semantic"], "extra": extra,
            "examples": examples}


def composition_reference_rates(pipe: EnergyMoGenPipeline, seed: int, per_case: int
                                ) -> dict[str, float]:
    """The reference arms of ``composition_study`` at ``seed`` sampled from ``pipe``: the best
    single concept's both-present rate (per held-out pair the better of the two single-concept
    generations, averaged over pairs) and the negation baseline's (c_i alone) negated- and
    kept-concept rates — the same items, texts, noise and batches as the study's, so on the
    study's own pipeline the same numbers, and on another training the A/A copy's."""
    items = composition_items(pipe.data, seed, pipe.config.items_per_pair)
    c1, c2 = items.concept_texts
    pairs = pair_index(items)

    def presence(texts: Sequence[str], concepts: Sequence[Sequence[str]]) -> np.ndarray:
        motion = pipe.decode(pipe.sample(Sampler("single"), [], texts, seed, batch=len(texts)))
        return oracle_presence(pipe.joints(motion), concepts)

    single1, single2 = presence(c1, items.concepts), presence(c2, items.concepts)
    best = np.maximum(per_pair_mean(single1.all(1), pairs), per_pair_mean(single2.all(1), pairs))
    neg = negation_items(seed, per_case)
    base = presence(neg.pair_texts, list(zip(neg.kept, neg.negated, strict=True)))
    return {"best_single_concept_both_present": float(best.mean()),
            "baseline_negated_present": float(base[:, 1].mean()),
            "baseline_kept_present": float(base[:, 0].mean())}


def composition_controls(source: PipelineSource, study: Mapping[str, Any] | NotMeasurable,
                         seeds: Sequence[int], *, per_case: int) -> dict[str, Controls] | None:
    """EMG-2/3's controls as A/A runs (``harness.aa_controls``). The reference arms are the
    study's baselines (the best single concept for conjunction, c_i alone for negation); the
    null is seed s's baselines (the study's) against the same baselines sampled, with seed
    s's items, texts and noise, from the pipeline of seed s' = ``copy_seed(seeds, s)`` (the
    run's next seed, cyclic, already trained; one seed: s + 1) in the compared arms' places:
    conjunction = the copy's best single concept, negation's negated rate = the copy's
    baseline negated rate, its kept rate = half the copy's baseline kept rate (the rule reads
    2·kept / baseline: the null sits on its threshold). Positive: the same A/A with twice each
    part's δ planted on the compared arm in the paper's direction. One copy per seed serves
    both claims (their baselines are the same samples). Returns ``{"EMG-2": controls,
    "EMG-3": controls}``; None on a data folder (``composition_study`` not measurable)."""
    if isinstance(study, NotMeasurable):
        return None
    copies = {int(s): copy_seed(seeds, s) for s in seeds}
    copy: dict[str, list[float]] = {}
    for seed, other in copies.items():
        rates = composition_reference_rates(pipeline_for(source, other), seed, per_case)
        for name, value in rates.items():
            copy.setdefault(name, []).append(value)
    slots = [AASlot(("conjunction_both_present",), ("best_single_concept_both_present",)),
             AASlot(("negation_negated_present",), ("baseline_negated_present",)),
             AASlot(("negation_kept_present",), ("baseline_kept_present",), factor=0.5)]
    targets = {"conjunction_carries_both": [("conjunction_both_present",)],
               "negation_removes_concept": [("negation_negated_present",)],
               "negation_keeps_other": [("negation_kept_present",)]}
    return {claim_id: aa_controls(claim_id, study[mode], copy, slots, targets, copies=copies,
                                  what="the baselines (best single concept, c_i alone)")
            for claim_id, mode in (("EMG-2", "latent"), ("EMG-3", "semantic"))}


def composition_study_text(study: Mapping[str, Any] | NotMeasurable) -> str:
    """The lines notebook 04 prints for ``composition_study``: each mode's six rates
    (mean ± 95 % half-width, per seed), the baselines and which concept a conjunction keeps;
    on a data folder the study's reason (``data.NotMeasurable``)."""
    if isinstance(study, NotMeasurable):
        return f"EMG-2/3: {study.reason}."
    lines, extra23 = [], study["extra"]
    for mode in ("latent", "semantic"):
        lines.append(f"--- {mode}")
        for name, values in study[mode].items():
            lines.append(f"{name:36s} {interval_text(values)}   "
                         f"per seed {np.round(values, 3).tolist()}")
    for name in ("unconditional_both_present", "multi_text_both_present",
                 "ground_truth_both_present", "single_concept_1_present",
                 "single_concept_2_present"):
        lines.append(f"{name:36s} {interval_text(extra23[name])}")
    for mode, rates in extra23["conjunction_concept_present"].items():
        lines.append(f"which concept survives ({mode}): leg/locomotion concept "
                     f"{interval_text(rates['lower'])}, arm concept {interval_text(rates['arm'])}")
    return "\n".join(lines)


def by_pair_markdown(study: Mapping[str, Any] | NotMeasurable) -> str:
    """Notebook 04's table of both-concepts-found rates by held-out pair (mean over seeds)."""
    if isinstance(study, NotMeasurable):
        return f"**Both concepts found, by held-out pair**: {study.reason}."
    by_pair = study["extra"]["by_pair"]
    rows = [[pair] + [f"{np.mean(by_pair[m][pair]):.2f}" if by_pair[m][pair] else "—"
                      for m in ("best_single", "multi_text", "latent", "semantic")]
            for pair in by_pair["latent"]]
    return ("**Both concepts found, by held-out pair (mean over seeds)**\n\n"
            + markdown_table(["held-out pair", "best single", "joined text", "latent Eq. 7",
                              "semantic Eq. 9"], rows))


def composition_notes(settings: EnergyViewSettings) -> str:
    """The notes EMG-2 and EMG-3 both record: the guidance and weights of each form, the items,
    the oracles and the models behind the study."""
    config, per_case = settings.pipeline, settings.negation_items_per_case
    choice_note = (f"Guidance s = {config.guidance_scale}; Eq. 7 w_i = s; Eq. 8 w = s; Eq. 9 "
                   "conjunction w^s = (1, 1), negation w^s = (1, −0.5), guided with s. "
                   f"Conjunction on the {len(HELD_OUT_PAIRS)} held-out pairs "
                   f"({config.items_per_pair} items each per seed); negation on "
                   f"{len(NEGATION_CASES)} trained pairs ({per_case} items each). Oracles: "
                   "repro.oracles.detect_concepts on the decoded joints. One trained model per "
                   "seed (VAE and denoiser trained with training seed data_seed + s for seed s; "
                   "data, frozen text encoder and evaluator fixed); seeds also vary items and "
                   "noise. Stand-in captions are complete (a single-concept clip keeps its "
                   "other body parts idle), so the product of single-concept conditionals "
                   "behind Eq. 7 is narrow; the joined-text rate is in extra.")
    return choice_note


def composition_extra(study: Mapping[str, Any]) -> dict[str, Any]:
    """What EMG-2 and EMG-3 both keep beside their rates from ``composition_study``: which
    concept a conjunction keeps, the baselines' both-present rates and the per-pair rates."""
    extra23 = study["extra"]
    return {"conjunction_concept_present": extra23["conjunction_concept_present"],
            "unconditional_both_present": extra23["unconditional_both_present"],
            "multi_text_both_present": extra23["multi_text_both_present"],
            "ground_truth_both_present": extra23["ground_truth_both_present"],
            "by_pair": extra23["by_pair"]}


def composition_headline(form: str, measured: Mapping[str, Sequence[float]]) -> str:
    """The headline of one composition form (``form``, e.g. "latent Eq. 7/8") from its
    ``measured`` rates (one mode of ``composition_study``): each rate beside its baseline."""
    m = measured
    return (f"{form}: both concepts {np.mean(m['conjunction_both_present']):.2f} vs "
            f"best single {np.mean(m['best_single_concept_both_present']):.2f}; negated "
            f"concept {np.mean(m['negation_negated_present']):.2f} vs "
            f"{np.mean(m['baseline_negated_present']):.2f}; kept "
            f"{np.mean(m['negation_kept_present']):.2f} vs "
            f"{np.mean(m['baseline_kept_present']):.2f}")


def guidance_scale_check(pipes: Callable[[int], EnergyMoGenPipeline],
                         settings: EnergyViewSettings, seeds: Sequence[int], *,
                         log: Callable[[str], None] = print) -> None:
    """Does EMG-2/3's verdict hinge on the guidance scale s? Their rules applied at each of
    ``settings.scale_check_scales`` on the first ``scale_check_seeds`` seeds (each its own
    model, ``pipes(seed)``) with fewer items; logged, not recorded, paper scale only."""
    if not settings.scale_check:
        log(f"{settings.scale} run: scale check skipped (paper scale only)")
        return
    if not pipes(seeds[0]).data.labelled:
        log(f"scale check: {not_measurable_reason(pipes(seeds[0]).data)}")
        return
    start = time.perf_counter()
    for other in settings.scale_check_scales:
        other_config = dataclasses.replace(settings.pipeline, guidance_scale=other,
                                           items_per_pair=settings.scale_check_items_per_pair)

        def other_pipe(sd: int, other_config: Any = other_config) -> EnergyMoGenPipeline:
            return dataclasses.replace(pipes(sd), config=other_config)

        other_study = composition_study(other_pipe, seeds[:settings.scale_check_seeds],
                                        per_case=settings.scale_check_items_per_case)
        for claim_id, mode in (("EMG-2", "latent"), ("EMG-3", "semantic")):
            decision = get_claim(claim_id).decide(other_study[mode])
            means = {k: round(float(np.mean(v)), 2) for k, v in other_study[mode].items()}
            log(f"s = {other}: {claim_id} {decision.verdict} — {means}")
    log(f"scale check took {time.perf_counter() - start:.1f} s")


def _bar_panel(ax: Axes, labels: Sequence[str], series: Sequence[Sequence[float]], title: str,
               ylabel: str) -> None:
    """Bars of the per-seed means with the seeds as dots."""
    for k, values in enumerate(series):
        values = np.asarray(values)
        ax.bar(k, values.mean(), color=f"C{k}", alpha=0.7)
        ax.plot(np.full(len(values), k) + np.linspace(-0.15, 0.15, len(values)), values, "k.",
                ms=4)
    ax.set_xticks(range(len(labels)), labels, rotation=30, ha="right", fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)


def composition_oracle_figure(study: Mapping[str, Any], seeds: Sequence[int],
                              guidance_scale: float) -> Figure:
    """EMG-2/3 (``composition_study``): conjunction both-present rates beside the
    baselines, and negation's negated and kept concepts."""
    lat, sem, extra = study["latent"], study["semantic"], study["extra"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    _bar_panel(axes[0], ["best single\nconcept", "∅", "joined text", "latent\nEq. 7",
                         "semantic\nEq. 9", "ground truth"],
               [lat["best_single_concept_both_present"], extra["unconditional_both_present"],
                extra["multi_text_both_present"], lat["conjunction_both_present"],
                sem["conjunction_both_present"], extra["ground_truth_both_present"]],
               "Conjunction (held-out pairs): both concepts found", "fraction of samples")
    _bar_panel(axes[1], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_negated_present"], lat["negation_negated_present"],
                sem["negation_negated_present"]], "Negation: negated concept still found", "")
    _bar_panel(axes[2], ["c_i alone", "latent\nEq. 8", "semantic\nEq. 9"],
               [lat["baseline_kept_present"], lat["negation_kept_present"],
                sem["negation_kept_present"]], "Negation: kept concept found", "")
    fig.suptitle(f"Dots: seeds {list(seeds)} (one trained model each); s = {guidance_scale}",
                 fontsize=9)
    return fig


def composition_examples_figure(examples: Mapping[str, np.ndarray]) -> Figure:
    """One filmstrip per sampler of ``composition_study``'s first item."""
    fig, axes = plt.subplots(len(examples), 1, figsize=(10, 1.9 * len(examples)))
    for ax, (name, joints) in zip(axes, examples.items(), strict=True):
        filmstrip(joints, frames=8, ax=ax, title=name)
    fig.suptitle("First item of the first seed, default model (conjunction: "
                 + " + ".join(HELD_OUT_PAIRS[0]) + "; negation: "
                 + " not ".join([" & ".join(NEGATION_CASES[0][0]), NEGATION_CASES[0][1]])
                 + ")", fontsize=9)
    return fig


def save_composition_figures(study: Mapping[str, Any] | NotMeasurable, seeds: Sequence[int],
                             scale: float, figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 04's EMG-2/3 figures saved under ``figure_path(name)``:
    :func:`composition_oracle_figure` and :func:`composition_examples_figure` (their paths, in
    that order); none for a ``NotMeasurable`` study (a data folder)."""
    if isinstance(study, NotMeasurable):
        return []
    return [save_figure(composition_oracle_figure(study, seeds, scale),
                        figure_path("emg2_emg3_composition_oracles.png")),
            save_figure(composition_examples_figure(study["examples"]),
                        figure_path("emg2_emg3_examples.png"))]
