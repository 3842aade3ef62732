"""Notebook 05's sets of three (outside the rules): the tables of every row of Tables 3, 7 and 9
on ``settings.THREE_CONCEPT_SETS`` (``common.run_rows(..., test_set="threes")``), of the
two-concept control on the same motions (``settings.THREES_AS_PAIRS``,
``test_set="threes_as_pairs"``), the summary's line on both (:func:`threes_markdown`,
:func:`control_markdown`, :func:`summary_line`) and their figure
(:func:`save_three_concepts_figure`). No number here enters a verdict; EMG-5's result keeps
them beside its own. On a data folder they compose the stand-in's concepts and are not
measurable (``data.NotMeasurable``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from repro.energymogen.data import NotMeasurable
from repro.energymogen.sef_ablation.common import (
    PAPER_TABLE7,
    PAPER_TABLE9,
    TABLE7_LAMBDAS,
    TABLE9_GAMMAS,
    Results,
    Rows,
    Study,
    gamma_key,
    lambda_key,
    markdown_table,
)
from repro.motion.plotting import save_figure

__all__ = [
    "control_markdown",
    "save_three_concepts_figure",
    "summary_line",
    "three_concepts_figure",
    "threes_markdown",
]

_REAL = [("real (ground truth)", "real")]
_THREE_COLUMNS = [("oracle_accuracy", "oracle acc."), ("both_present", "all found"),
                  ("oracle_accuracy_concept_1", "lower found"),
                  ("oracle_accuracy_concept_2", "left wave found"),
                  ("oracle_accuracy_concept_3", "right wave found"),
                  ("foot_skating", "foot skate m/s"), ("jitter", "jitter m/s²")]
_CONTROL_COLUMNS = [("oracle_accuracy", "oracle acc."), ("both_present", "both found"),
                    ("oracle_accuracy_concept_1", "lower found"),
                    ("oracle_accuracy_concept_2", "wave_both found"),
                    ("r_precision_top3", "R@3 %"), ("fid", "FID")]


def threes_markdown(results3: Study, t3_rows: Rows, paper3: Mapping[str, Any]) -> str:
    """The sets of three's tables: Table 3's rows (``t3_rows``: label, row key; ``paper3``: the
    paper's values by row key), Table 7's λ grid, Table 9's step sizes and the columns beyond
    the paper's."""
    if isinstance(results3, NotMeasurable):
        return f"**Sets of three**: {results3.reason}."
    t7_rows = [(f"({lambda_key(lam)})", lambda_key(lam)) for lam in TABLE7_LAMBDAS]
    t9_keys = [gamma_key(g) for g in TABLE9_GAMMAS]
    return "\n\n".join([
        "**Table 3's rows**\n\n" + markdown_table(results3, t3_rows, paper3),
        "**Table 7 (λ grid)**\n\n" + markdown_table(
            results3, t7_rows, PAPER_TABLE7,
            [("r_precision_top3", "R@3 %"), ("fid", "FID"),
             ("transition_distance", "all-frames Trans. cm (v2)"),
             ("both_present", "all found")]),
        "**Table 9 (AGD step sizes)**\n\n" + markdown_table(
            results3, [(f"[{k}]", k) for k in t9_keys], PAPER_TABLE9,
            [("r_precision_top3", "R@3 %"), ("fid", "FID")]),
        "**Beyond the paper's columns** (no paper values)\n\n"
        + markdown_table(results3, list(t3_rows) + _REAL, {}, _THREE_COLUMNS)])


def control_markdown(results3_control: Study, t3_rows: Rows) -> str:
    """The control's table: the same motions named as two concepts (lower + wave_both)."""
    if isinstance(results3_control, NotMeasurable):
        return f"**Control of the sets of three**: {results3_control.reason}."
    return ("**Control: the same motions as two concepts (lower + wave_both)**\n\n"
            + markdown_table(results3_control, list(t3_rows) + _REAL, {}, _CONTROL_COLUMNS))


def summary_line(results: Results, results3: Study, results3_control: Study,
                 t3_rows: Rows) -> str:
    """The summary's line on the sets of three: all three found per Table 3 row, the same
    motions as lower + wave_both, and the held-out pairs' both-found rate."""
    if isinstance(results3, NotMeasurable):
        return f"- Sets of three (outside the rules): {results3.reason}."

    def rates(found: Results) -> str:
        return ", ".join(f"{label} {np.mean(found[key]['both_present']):.0%}"
                         for label, key in t3_rows)

    return ("- Sets of three (outside the rules): all three found for " + rates(results3)
            + "; the same motions as lower + wave_both (control): both found for "
            + rates(results3_control) + "; on the held-out pairs both found for "
            + rates(results))


def save_three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results,
                               threes: Results | NotMeasurable,
                               control: Results | NotMeasurable,
                               figure_path: Callable[[str], Path]) -> list[Path]:
    """Notebook 05's :func:`three_concepts_figure` saved under ``figure_path(name)`` (its path
    in a list); none when the sets of three are not measurable (a data folder)."""
    if isinstance(threes, NotMeasurable) or isinstance(control, NotMeasurable):
        return []
    return [save_figure(three_concepts_figure(rows, pairs, threes, control),
                        figure_path("emg5_three_concepts.png"))]


def three_concepts_figure(rows: Sequence[tuple[str, str]], pairs: Results, threes: Results,
                          control: Results) -> Figure:
    """Table 3's ``rows`` (label, key) on the held-out pairs, the sets of three and their
    two-concept control: all concepts found and R@3, dots per seed."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.6))
    labels = [label for label, _ in rows]
    groups = (("held-out pairs", pairs), ("sets of three", threes),
              ("control: same motions as lower + wave_both", control))
    for ax, metric, title in zip(axes, ("both_present", "r_precision_top3"),
                                 ("all concepts found by the oracles", "R@3 (%)"), strict=True):
        for offset, (name, res) in zip((-0.27, 0.0, 0.27), groups, strict=True):
            values = [np.asarray(res[key][metric], dtype=float) for _, key in rows]
            ax.bar(np.arange(len(rows)) + offset, [v.mean() for v in values], width=0.27,
                   label=name, alpha=0.7)
            for k, v in enumerate(values):
                ax.plot(np.full(len(v), k + offset), v, "k.", ms=4)
        ax.set_xticks(range(len(rows)), labels, rotation=15, fontsize=8)
        ax.set_title(title + " (dots: seeds)", fontsize=9)
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=3, fontsize=8)
    fig.subplots_adjust(bottom=0.27)
    fig.suptitle("Table 3's rows on the held-out pairs, the sets of three and their two-concept "
                 "control (same models, seeds and rows)", fontsize=9)
    return fig
