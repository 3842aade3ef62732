"""Relative vs absolute root representation (GMD appendix B; claims GMD-B1…B3): the logic of
``notebooks/02_root_representation.ipynb``, on top of the tiny-GMD modules of ``repro.gmd``.

One module per claim, each with its experiment, controls, figures, reading and result
(``b1_result``, ``b2_result``, ``b3_result``; the rules stay in ``repro.claims.registry_gmd``):

- ``b1`` (GMD-B1): the exact round trip between the representations and the sensitivity
  study — how a change at one frame moves the global root path in each.
- ``b2`` (GMD-B2): location imputation and guidance in both representations, like for like.
- ``b3`` (GMD-B3): Table B.1's evaluation (``measurements``) run on both, except at a scale
  that runs none of B3's parts (``Settings.runs_b3``: the claim is recorded as not run, with
  why).
- ``common``: what the claims share — the notebook's fixed settings (:class:`Settings`), the
  table of a run's numbers, loading or training one model per representation and seed, each
  representation's gate role.

The result functions run the experiments at the notebook's :class:`Settings`, build the
fitness-gate records of the models behind B2 and B3 (``model_gates``), run each claim's
controls and return what its registered rule reads with the sidecar's headline, notes and
extra values; the notebook then calls ``record(ctx, result)``. Representations are named as
``motion.humanml3d.REPRESENTATIONS`` ("relative", "absolute"); "rel"/"abs"
(``windows.short_label``) only name measurements.

Re-exported here: the names the notebook reads (as ``rr.<name>``) and :class:`Settings`, which
``repro.run.params``, the tests' ``conftest`` and ``scripts/`` read.
"""

from __future__ import annotations

from repro.gmd.root_representation.b1 import (
    REAL_CLIP,
    b1_figures,
    b1_reading,
    b1_result,
    b1_study,
    round_trip_markdown,
)
from repro.gmd.root_representation.b2 import (
    METHODS,
    REGISTERED_METHODS,
    b2_model_records,
    b2_result,
    b2_runs,
    b2_table_markdown,
    plot_imputation,
    plot_method_errors,
    reading_b2,
)
from repro.gmd.root_representation.b3 import (
    b3_evaluation,
    b3_model_records,
    b3_not_run_markdown,
    b3_not_run_result,
    b3_result,
    b3_rows,
    reading_b3,
)
from repro.gmd.root_representation.common import (
    Settings,
    load_or_train_per_representation,
    settings_markdown,
    window_needs,
)

__all__ = ["METHODS", "REAL_CLIP", "REGISTERED_METHODS", "Settings", "b1_figures", "b1_reading",
           "b1_result", "b1_study", "b2_model_records", "b2_result", "b2_runs",
           "b2_table_markdown", "b3_evaluation", "b3_model_records", "b3_not_run_markdown",
           "b3_not_run_result", "b3_result", "b3_rows", "load_or_train_per_representation",
           "plot_imputation", "plot_method_errors", "reading_b2", "reading_b3",
           "round_trip_markdown", "settings_markdown", "window_needs"]
