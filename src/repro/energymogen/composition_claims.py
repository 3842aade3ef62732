"""The composition claims as notebooks 04 and 05 record them, from the studies of
``energymogen.studies``:

- **EMG-2 / EMG-3** (Sec. 3.2 ❶ Eq. 7–8, ❷ Eq. 9: latent- and semantic-aware conjunction and
  negation), oracle-measured by ``studies.composition_study``: :func:`emg23_results`; the
  guidance-scale check beside them (paper scale only, not recorded):
  :func:`guidance_scale_check`;
- **EMG-4** (app. E, Table 9: "[γ_attn, γ_reg] = [0.001, 0.002] achieves best results on MTT")
  and **EMG-5** (Sec. 5.5 Q2, Tables 3 and 7: "Synergistic Energy Fusion (SEF) effectively
  alleviates these issues"), from ``studies.run_rows`` and ``studies.timeline_rows``:
  :func:`emg4_result`, :func:`emg5_result`.

Each returns the :class:`~repro.claims.result.ClaimResult` the notebook records: what the
registered rule reads, headline, notes and the values kept beside them.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from repro.claims.registry import get_claim
from repro.claims.result import ClaimResult, Controls, not_measurable_result
from repro.core.tables import interval_text, markdown_table
from repro.energymogen import rule_settings
from repro.energymogen.config import (
    HELD_OUT_PAIRS,
    NEGATION_CASES,
    THREE_CONCEPT_SETS,
    THREES_AS_PAIRS,
)
from repro.energymogen.data import NotMeasurable, not_measurable_reason
from repro.energymogen.pipeline import EnergyMoGenPipeline
from repro.energymogen.settings import EnergyViewSettings, SEFAblationSettings
from repro.energymogen.studies import (
    PAPER_TABLE3,
    PAPER_TABLE7,
    PAPER_TABLE9,
    TABLE7_LAMBDAS,
    TABLE9_GAMMAS,
    composition_study,
    gamma_key,
    lambda_key,
)

__all__ = ["by_pair_markdown", "composition_study_text", "emg23_results", "emg4_result",
           "emg5_result", "guidance_scale_check"]

Results = Mapping[str, Mapping[str, Any]]
Figures = Sequence[str | os.PathLike]
Models = Sequence[Mapping[str, Any]]

#: EMG-5's rows: latent only, semantic only, SEF (Table 3's λ)
_LAT, _SEM, _SEF = "1.0,0.0,0.0", "0.0,1.0,0.0", "0.1,0.7,0.2"


def composition_study_text(study: Mapping[str, Any] | NotMeasurable) -> str:
    """The lines notebook 04 prints for ``studies.composition_study``: each mode's six rates
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


def emg23_results(study: Mapping[str, Any] | NotMeasurable,
                  controls: Mapping[str, Controls] | None,
                  settings: EnergyViewSettings, seeds: Sequence[int], *, models: Models,
                  figures: Figures) -> tuple[ClaimResult, ClaimResult]:
    """EMG-2 (latent Eq. 7/8) and EMG-3 (semantic Eq. 9) from ``studies.composition_study``
    (``study``) and ``controls.composition_controls`` (``controls``: claim → its controls),
    with the study's baselines and per-pair rates beside them. On a data folder (``study`` a
    ``data.NotMeasurable``) both are not measurable on real data: nothing is recorded as
    measured (``claims.result.not_measurable_result``)."""
    if isinstance(study, NotMeasurable):
        used = rule_settings.emg23(settings)
        return (not_measurable_result("EMG-2", study.reason, seeds, settings=used, models=models),
                not_measurable_result("EMG-3", study.reason, seeds, settings=used, models=models))
    config, per_case, extra23 = settings.pipeline, settings.negation_items_per_case, study["extra"]
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
    emg_extra = {"conjunction_concept_present": extra23["conjunction_concept_present"],
                 "unconditional_both_present": extra23["unconditional_both_present"],
                 "multi_text_both_present": extra23["multi_text_both_present"],
                 "ground_truth_both_present": extra23["ground_truth_both_present"],
                 "by_pair": extra23["by_pair"]}

    def result(claim_id: str, mode: str, form: str) -> ClaimResult:
        m = study[mode]
        headline = (f"{form}: both concepts {np.mean(m['conjunction_both_present']):.2f} vs "
                    f"best single {np.mean(m['best_single_concept_both_present']):.2f}; negated "
                    f"concept {np.mean(m['negation_negated_present']):.2f} vs "
                    f"{np.mean(m['baseline_negated_present']):.2f}; kept "
                    f"{np.mean(m['negation_kept_present']):.2f} vs "
                    f"{np.mean(m['baseline_kept_present']):.2f}")
        return ClaimResult(claim_id, m, seeds=seeds, settings=rule_settings.emg23(settings),
                           controls=controls[claim_id], models=models,
                           figures=figures, headline=headline, notes=choice_note,
                           extra={**emg_extra,
                                  "control_calibration": controls[claim_id].planted})

    return (result("EMG-2", "latent", "latent Eq. 7/8"),
            result("EMG-3", "semantic", "semantic Eq. 9"))


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


def _common_notes(settings: SEFAblationSettings) -> str:
    config = settings.pipeline
    return (f"Guidance s = {config.guidance_scale} (Eq. 7 w_i = s; Eq. 9 w^s = (1, 1) and the "
            f"single text guided with s); DDIM {config.ddim_steps}; "
            f"{len(HELD_OUT_PAIRS)} held-out pairs × {config.items_per_pair} items per "
            f"seed (R@3); transitions on {settings.timeline_items} MTT-style timeline items "
            "per seed: STMC's distance at every boundary (cm) and its ratio to the clip's "
            "mean speed (ε = 0.01 cm/frame); real = generator 'then' clips at their labelled "
            "transitions; R-precision/TMR/FID with our tiny evaluator. One "
            "trained model per seed (VAE and denoiser trained with training seed "
            "data_seed + s for seed s; data, frozen text encoder and evaluator "
            "fixed); seeds also vary items and noise.")


def _table(results: Results) -> dict[str, dict[str, Any]]:
    return {key: {metric: values for metric, values in results[key].items()} for key in results}


def emg5_result(results: Results, timelines: Results | NotMeasurable,
                settings: SEFAblationSettings, seeds: Sequence[int], *,
                three_concepts: Results | NotMeasurable,
                three_concepts_control: Results | NotMeasurable, controls: Controls | None,
                models: Models, figures: Figures) -> ClaimResult:
    """EMG-5 from the Table 7 rows of ``studies.run_rows`` (``results``: row → metric →
    per-seed list, R@3 on the held-out pairs) and ``studies.timeline_rows`` (``timelines``:
    the transitions at the MTT-style timelines' boundaries); the sets of three
    (``three_concepts``, outside the rules) and their two-concept control kept beside. On a
    data folder (``timelines`` a ``data.NotMeasurable``: the λ rows compose concepts) not
    measurable on real data (``claims.result.not_measurable_result``)."""
    if isinstance(timelines, NotMeasurable):
        return not_measurable_result("EMG-5", timelines.reason, seeds, models=models,
                                     settings=rule_settings.emg5(settings))
    t7_keys = [lambda_key(lam) for lam in TABLE7_LAMBDAS]
    r3 = {key: results[key]["r_precision_top3"] for key in t7_keys}
    trans_all = {key: results[key]["transition_distance"] for key in t7_keys}
    trans = {key: timelines[key]["transition_distance_at_transitions"] for key in t7_keys}
    ratio = {key: timelines[key]["transition_speed_ratio"] for key in t7_keys}
    real = timelines["real"]
    headline = (f"R@3 latent/semantic/SEF {np.mean(r3[_LAT]):.1f}/{np.mean(r3[_SEM]):.1f}/"
                f"{np.mean(r3[_SEF]):.1f} %; transition at the boundaries "
                f"{np.mean(trans[_LAT]):.2f}/{np.mean(trans[_SEM]):.2f}/"
                f"{np.mean(trans[_SEF]):.2f} cm (real 'then' clips "
                f"{np.mean(real['transition_distance_at_transitions']):.2f}), ratio to "
                f"mean speed {np.mean(ratio[_LAT]):.2f}/{np.mean(ratio[_SEM]):.2f}/"
                f"{np.mean(ratio[_SEF]):.2f} (real "
                f"{np.mean(real['transition_speed_ratio']):.2f})")
    extra = {"table": _table(results), "timeline_table": timelines,
             "timeline_items_per_seed": settings.timeline_items,
             "paper_table7": PAPER_TABLE7, "paper_table3": PAPER_TABLE3,
             "three_concept_sets": [list(names) for names in THREE_CONCEPT_SETS],
             "three_concept_table": three_concepts,
             "three_concept_control_sets": [list(names) for names in THREES_AS_PAIRS],
             "three_concept_control_table": three_concepts_control,
             "control_calibration": controls.planted}
    measured = {"r_precision_top3": r3, "transition_distance_at_transitions": trans,
                "transition_speed_ratio": ratio, "transition_distance": trans_all}
    return ClaimResult("EMG-5", measured, seeds=seeds, settings=rule_settings.emg5(settings),
                       controls=controls, models=models,
                       figures=figures, headline=headline,
                       notes=_common_notes(settings) + " λ grid with AGD off.", extra=extra)


def emg4_result(results: Results, agd_change: Mapping[str, float],
                settings: SEFAblationSettings, seeds: Sequence[int], *, controls: Controls,
                models: Models, figures: Figures,
                data_dir: str | os.PathLike | None = None) -> ClaimResult:
    """EMG-4 from the Table 9 rows of ``studies.run_rows`` (``results``, single-text
    generation with AGD) and ``studies.agd_relative_change`` (``agd_change``: γ row → the
    text embedding's relative change, the first seed's model). ``data_dir``: the run's data
    folder (None: the stand-in set), whose test windows and captions the rows then used
    (the notes say so)."""
    gkeys = [gamma_key(g) for g in TABLE9_GAMMAS]
    table = _table(results)
    headline = ("R@3 by [γattn, γreg]: " + ", ".join(
        f"[{k}] {np.mean(results[k]['r_precision_top3']):.1f}" for k in gkeys)
        + " %; ‖Δc‖/‖c‖ at [0.1,0.2] = " + f"{agd_change['0.1,0.2']:.1e}")
    notes = _common_notes(settings) + (
        " Single-text generation with AGD in every cross-attention layer (restarting from the "
        "encoder's embedding at every step). Our text embedding's scale differs from CLIP's, "
        "so γ values are not directly comparable: relative embedding change per row (first "
        "seed's model) is in extra.")
    if data_dir is not None:
        notes += (f" Data folder {data_dir} (real data): the rows generate from the captions of "
                  "its test windows (data.energy_view_items: one caption per window, as many "
                  "windows as the pairs' items, at most all), R@3 against those windows in "
                  "batches of 32, FID against all its test windows; no held-out pair, timeline "
                  "or oracle is read (EMG-5's compositions are not measurable there).")
    extra = {"agd_relative_embedding_change": agd_change, "paper_table9": PAPER_TABLE9,
             "table": {k: table[k] for k in gkeys}, "control_calibration": controls.planted}
    return ClaimResult("EMG-4", {"r_precision_top3": {key: results[key]["r_precision_top3"]
                                                      for key in gkeys}},
                       seeds=seeds, settings=rule_settings.emg4(settings), controls=controls,
                       models=models, figures=figures, headline=headline, notes=notes,
                       extra=extra)
