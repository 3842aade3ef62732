"""Notebook 05's shared parts (EMG-4 and EMG-5): the settings (:class:`SEFAblationSettings`),
the paper's rows of Tables 3 (Sec. 5.4), 7 (appendix C, the λ of Eq. 10) and 9 (appendix E, the
γ of Eq. 4), keyed as the registry spells them (:func:`lambda_key`, :func:`gamma_key`),
measured over seeds, one pipeline or one trained model per seed (``pipeline.SeedPipelines``),
by :func:`run_rows` and shown beside the paper's values (:func:`markdown_table`); the notes,
tables and seed statistics both claims' results and figures use."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from repro.core import tables
from repro.core.tables import interval_text
from repro.energymogen.data import (
    NotMeasurable,
    composition_items,
    energy_view_items,
    load_or_build_test_pool,
    not_measurable_reason,
)
from repro.energymogen.harness import composition_metrics
from repro.energymogen.pipeline import PipelineSource, Sampler, pipeline_for
from repro.energymogen.settings import (
    AGD_CHANGE_T,
    AGD_LARGEST_CHANGE,
    HELD_OUT_PAIRS,
    TABLE9_ITEMS_PER_PAIR,
    NotebookSettings,
    PipelineConfig,
    TrainingPlan,
    pipeline_config,
    seeds_of,
)
from repro.infra.context import check_scale
from repro.standin.figures import NOT_MEASURABLE

__all__ = [
    "PAPER_TABLE3",
    "PAPER_TABLE7",
    "PAPER_TABLE9",
    "Results",
    "Rows",
    "SEFAblationSettings",
    "Study",
    "TABLE7_LAMBDAS",
    "TABLE9_GAMMAS",
    "common_notes",
    "gamma_key",
    "lambda_key",
    "markdown_table",
    "mean_sem",
    "result_table",
    "run_rows",
]


@dataclass(frozen=True)
class SEFAblationSettings(NotebookSettings):
    """Notebook 05 (EMG-4, EMG-5): the pipeline, the number of seeds and the MTT-style
    timeline items per seed on which EMG-5's transitions are measured
    (``emg5.timeline_items``; 64 at standard and paper, our choice: 1–3 boundaries each,
    about 150 transitions per row and seed, one item in eight of MTT's 500; 8 in quick runs)
    and the training plan (every EnergyMoGen notebook's: one trained pipeline). EMG-4's
    Table 9 rows run on ``table9_items_per_pair`` items per held-out pair
    (``settings.TABLE9_ITEMS_PER_PAIR``, 32, at standard and paper; the pipeline's in quick runs)
    at the paper's step sizes transferred: κ × [γ_attn, γ_reg] per seed, κ such that
    [0.1, 0.2] moves the text embedding by ‖Δc‖/‖c‖ = ``agd_largest_change`` at t =
    ``agd_change_t`` (``emg4.agd_scale``). On a data folder EMG-4 is measured (Table 9's
    single-text rows with AGD, from the captions of the folder's test windows, R@3 and FID
    against them); EMG-5 (the λ rows compose concepts; the timelines and the sets of three are
    the stand-in's) is recorded as not measurable on real data."""

    NOTEBOOK: ClassVar[str] = "05_sef_ablation"
    scale: str
    pipeline: PipelineConfig
    plan: TrainingPlan
    seeds: int
    timeline_items: int
    table9_items_per_pair: int
    agd_largest_change: float = AGD_LARGEST_CHANGE
    agd_change_t: int = AGD_CHANGE_T

    @property
    def quick(self) -> bool:
        return self.scale == "quick"

    @property
    def table9_items(self) -> int:
        """Table 9's test items per row and seed (every held-out pair's)."""
        return self.table9_items_per_pair * len(HELD_OUT_PAIRS)

    @classmethod
    def for_scale(cls, scale: str) -> SEFAblationSettings:
        """The settings of ``scale``, checked here once (its helpers take a valid scale)."""
        scale = check_scale(scale)
        config = pipeline_config(scale)
        return cls(scale=scale, pipeline=config, plan=TrainingPlan.for_scale(scale),
                   seeds=seeds_of("EMG-4", scale),
                   timeline_items=8 if scale == "quick" else 64,
                   table9_items_per_pair=(config.items_per_pair if scale == "quick"
                                          else TABLE9_ITEMS_PER_PAIR))


Results = Mapping[str, Mapping[str, Any]]
Study = Results | NotMeasurable
Rows = Sequence[tuple[str, str]]


# --- the paper's rows (R@1, R@3 in %, TMR M2T, M2M, FID, transition distance) ----------------
_COLUMNS = ("r_precision_top1", "r_precision_top3", "tmr_m2t", "tmr_m2m", "fid",
            "transition_distance")
TABLE7_LAMBDAS: tuple[tuple[float, float, float], ...] = (
    (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.5, 0.5, 0.0), (0.4, 0.6, 0.0),
    (0.3, 0.7, 0.0), (0.2, 0.8, 0.0), (0.1, 0.9, 0.0), (0.3, 0.4, 0.3), (0.2, 0.5, 0.3),
    (0.1, 0.7, 0.2), (0.1, 0.8, 0.1))
TABLE9_GAMMAS: tuple[tuple[float, float], ...] = (
    (0.0, 0.0), (0.1, 0.2), (0.01, 0.02), (0.005, 0.01), (0.005, 0.005), (0.001, 0.002))
_T7 = ((9.7, 19.6, 0.547, 0.521, 0.917, 1.6), (15.1, 27.5, 0.585, 0.567, 0.569, 2.2),
       (12.7, 25.4, 0.570, 0.562, 0.592, 2.7), (13.3, 25.5, 0.584, 0.551, 0.740, 1.4),
       (12.7, 25.0, 0.584, 0.555, 0.730, 1.4), (13.4, 26.4, 0.589, 0.559, 0.694, 1.4),
       (13.6, 26.9, 0.590, 0.558, 0.668, 1.5), (14.2, 27.5, 0.587, 0.563, 0.613, 1.7),
       (14.5, 27.1, 0.588, 0.560, 0.669, 1.6), (14.4, 26.9, 0.590, 0.563, 0.628, 1.6),
       (15.7, 28.0, 0.591, 0.567, 0.604, 1.6), (14.9, 26.7, 0.587, 0.563, 0.615, 1.6))
_T9 = ((12.7, 25.4, 0.570, 0.562, 0.592, 2.7), (1.4, 4.2, 0.498, 0.495, 1.083, 6.1),
       (9.1, 20.1, 0.551, 0.547, 0.623, 2.9), (6.7, 15.3, 0.531, 0.523, 0.806, 1.9),
       (13.8, 25.6, 0.570, 0.558, 0.591, 2.7), (14.0, 26.3, 0.570, 0.560, 0.587, 2.7))
_T3 = {"single text": (12.7, 25.4, 0.570, 0.562, 0.592, 2.7),
       "single text + AGD": (14.0, 26.3, 0.570, 0.560, 0.587, 2.7),
       "latent only": (9.7, 19.6, 0.547, 0.521, 0.917, 1.6),
       "semantic only": (15.1, 27.5, 0.585, 0.567, 0.569, 2.2),
       "SEF": (15.9, 28.0, 0.591, 0.567, 0.604, 1.6)}


def lambda_key(lambdas: Sequence[float]) -> str:
    """``"λl,λs,λm"`` as the registry's EMG-5 rows spell it (``"0.1,0.7,0.2"``)."""
    return ",".join(str(float(v)) for v in lambdas)


def gamma_key(gammas: Sequence[float]) -> str:
    """``"γattn,γreg"`` as the registry's EMG-4 rows spell it (``"0.001,0.002"``)."""
    return ",".join(str(float(v)) for v in gammas)


#: Table 7 (appendix C): "λl,λs,λm" → the paper's row; Table 9 (appendix E): "γattn,γreg" → row;
#: Table 3 (Sec. 5.4, EnergyMoGen rows). Transition distance as printed (STMC's ×100 scale).
PAPER_TABLE7 = {lambda_key(k): dict(zip(_COLUMNS, v, strict=True))
                for k, v in zip(TABLE7_LAMBDAS, _T7, strict=True)}
PAPER_TABLE9 = {gamma_key(k): dict(zip(_COLUMNS, v, strict=True))
                for k, v in zip(TABLE9_GAMMAS, _T9, strict=True)}
PAPER_TABLE3 = {k: dict(zip(_COLUMNS, v, strict=True)) for k, v in _T3.items()}


def run_rows(source: PipelineSource, rows: Mapping[str, Sampler], seeds: Sequence[int],
             log: Callable[[str], None] | None = None, *, test_set: str = "pairs",
             items_per_pair: int | None = None
             ) -> dict[str, dict[str, list[float]]] | NotMeasurable:
    """Every row of a table on the composition items of every seed: row → metric → per-seed
    list. Seed s uses ``pipeline_for(source, s)`` (one pipeline, or one trained model per seed:
    ``pipeline.SeedPipelines``). Within a seed all rows share the model, the items and the initial
    noise; rows with the same canonical sampler are sampled once. The ground truth is measured
    as row ``"real"``.

    ``test_set``: ``"pairs"`` (the held-out pairs, ``items_per_pair`` each, by default the
    pipeline's; FID against ``pipe.reference_embeddings``) or a name of ``EXTRA_TEST_SETS``
    (``"threes"``: the sets of three; ``"threes_as_pairs"``: their control;
    ``items_per_extra_set`` each; FID against that set's own ground-truth pool).

    On a data folder (``data.labelled`` False) the items of ``"pairs"`` are its test windows
    with their captions (``data.energy_view_items``; FID against all its test windows) and
    only the rows of single-text samplers are measured (the text-to-motion rows: Table 9's
    AGD steps); a row that composes texts stays empty (no concepts to compose) and every
    other test set is a ``data.NotMeasurable`` (they compose the stand-in's concepts).
    """
    if test_set != "pairs" and not pipeline_for(source, seeds[0]).data.labelled:
        return NotMeasurable(not_measurable_reason(pipeline_for(source, seeds[0]).data))
    out: dict[str, dict[str, list[float]]] = {name: {} for name in [*rows, "real"]}
    for seed in seeds:
        pipe = pipeline_for(source, seed)
        reference = None
        if test_set == "pairs":
            items = energy_view_items(pipe.data, seed, items_per_pair
                                      or pipe.config.items_per_pair)
        else:
            pool = load_or_build_test_pool(pipe.config, test_set)
            items = composition_items(pipe.data, seed, pipe.config.items_per_extra_set, pool)
            reference = pipe.evaluator.embed_motions(
                pool.features, np.full(len(pool.features), pool.features.shape[1]))
        done: dict[Sampler, dict[str, float]] = {}
        start = time.perf_counter()
        for name, sampler in rows.items():
            key = sampler.canonical()
            if not (pipe.data.labelled or key.mode == "single"):
                continue   # a data folder: nothing to compose, the row stays empty
            if key not in done:
                features = pipe.decode(pipe.sample_items(key, items, seed))
                done[key] = composition_metrics(pipe, features, pipe.joints(features), items,
                                                seed, reference)
            for metric, value in done[key].items():
                out[name].setdefault(metric, []).append(value)
        # a data folder's windows carry no joints of their own: recovered from the features
        real_joints = items.gt_joints if pipe.data.labelled else pipe.joints(items.gt_features)
        real = composition_metrics(pipe, items.gt_features, real_joints, items, seed, reference)
        for metric, value in real.items():
            out["real"].setdefault(metric, []).append(value)
        if log is not None:
            log(f"seed {seed}: {len(done)} samplers in {time.perf_counter() - start:.1f} s")
    return out

#: the paper's column a measurement of ours stands beside: Table 3/7/9's transition distance is
#: STMC's, measured at a timeline's boundaries; our all-frames distance has no paper value
_PAPER_COLUMN: dict[str, str | None] = {
    "transition_distance_at_transitions": "transition_distance", "transition_distance": None}


def markdown_table(results: Mapping[str, Mapping[str, Sequence[float]]],
                   rows: Sequence[tuple[str, str]], paper: Mapping[str, Mapping[str, float]],
                   columns: Sequence[tuple[str, str]] = (
                       ("r_precision_top1", "R@1 %"), ("r_precision_top3", "R@3 %"),
                       ("tmr_m2t", "M2T"), ("tmr_m2m", "M2M"), ("fid", "FID"),
                       ("transition_distance_at_transitions", "Trans. cm"))) -> str:
    """A markdown table: per row (label, key) ours (mean ± 95 % half-width over seeds; "—"
    where the row or the measurement is absent; "not measurable on real data" for a row
    :func:`run_rows` left empty or a NaN value: a data folder's) and the paper's value in
    brackets (the transition distance at the boundaries beside the paper's transition
    distance)."""
    header = ["row"] + [f"{c} ours [paper]" for _, c in columns]
    body = []
    for label, key in rows:
        cells: list[object] = [label]
        for metric, _ in columns:
            values = results.get(key, {}).get(metric)
            if (key in results and not results[key]) or (
                    values is not None and np.isnan(np.asarray(values, dtype=float)).any()):
                ours = NOT_MEASURABLE
            else:
                ours = interval_text(values) if values is not None else "—"
            paper_metric = _PAPER_COLUMN.get(metric, metric)
            theirs = paper.get(key, {}).get(paper_metric) if paper_metric else None
            cells.append(f"{ours} [{theirs if theirs is not None else '—'}]")
        body.append(cells)
    return tables.markdown_table(header, body)


def common_notes(settings: SEFAblationSettings) -> str:
    """The notes EMG-4's and EMG-5's results both open with: guidance, DDIM steps, the items
    per seed, the timelines' transition measurements, the evaluator and the seeds' models."""
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


def result_table(results: Results) -> dict[str, dict[str, Any]]:
    """``results`` (row → metric → per-seed values) as plain dicts, for a result's extra."""
    return {key: {metric: values for metric, values in results[key].items()} for key in results}


def mean_sem(results: Results, key: str, metric: str) -> tuple[float, float]:
    """Mean and standard error over seeds (0 for one seed)."""
    values = np.asarray(results[key][metric], dtype=float)
    half = values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else 0.0
    return float(values.mean()), float(half)
