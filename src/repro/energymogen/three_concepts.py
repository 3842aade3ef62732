"""Notebook 05's sets of three concepts (outside the rules): the tables of every row of
Tables 3, 7 and 9 on ``config.THREE_CONCEPT_SETS`` (``studies.run_rows(...,
test_set="threes")``), of the two-concept control on the same motions
(``config.THREES_AS_PAIRS``, ``test_set="threes_as_pairs"``), and the summary's line on both.
No number here enters a verdict. On a data folder the sets of three are not measurable (they
compose the stand-in's concepts): every function here then says so (``data.NotMeasurable``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from repro.energymogen.data import NotMeasurable
from repro.energymogen.studies import (
    PAPER_TABLE7,
    PAPER_TABLE9,
    TABLE7_LAMBDAS,
    TABLE9_GAMMAS,
    gamma_key,
    lambda_key,
    markdown_table,
)

__all__ = ["control_markdown", "summary_line", "threes_markdown"]

Results = Mapping[str, Mapping[str, Any]]
Study = Results | NotMeasurable
Rows = Sequence[tuple[str, str]]

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
