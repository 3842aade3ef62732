"""The report's figures: every part's effect in units of its δ (``figures/parts_forest.png``)
and every claim by outcome (``figures/claims_by_outcome.png``).

The forest plot (as the Many Labs and Reproducibility Project reports show theirs): one row
per comparison of every part, grouped by claim in registry order; the part's mean per-seed
difference (or log ratio) over δ with its 95 % interval over δ, so every part reads on one
axis: the band ±1 is the smallest effect of interest, right of +1 the paper's effect or more,
left of −1 the opposite; the marker's colour is the part's outcome. Exact checks, and parts
with no interval (not recorded, not measurable), are listed without one.

The outcome figure: one row per registry claim: its parts as equal segments coloured by
outcome (supported, contradicted, absent, inconclusive, below resolution), the verdict written
beside it. A claim
without parts (a version 1 sidecar) is one hatched segment in its verdict's colour
(reproduced green, partially or inconclusive yellow, not reproduced or a discrepancy red);
one not recorded is grey.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from repro.claims.provenance import is_result  # noqa: E402
from repro.claims.registry import CLAIMS  # noqa: E402
from repro.claims.verdicts import (  # noqa: E402
    ABSENT,
    BELOW_RESOLUTION,
    CONTRADICTED,
    INCONCLUSIVE,
    NOT_REPRODUCED,
    PAPER_DISCREPANCY,
    PARTIAL,
    REPRODUCED,
    SUPPORTED,
)
from repro.infra.storage import write_bytes  # noqa: E402

FIGURE_NAME = "claims_by_outcome.png"
FOREST_NAME = "parts_forest.png"
OUTCOME_COLOURS = {SUPPORTED: "#2e7d32", CONTRADICTED: "#c62828", ABSENT: "#1565c0",
                   INCONCLUSIVE: "#f9a825", BELOW_RESOLUTION: "#8e7cc3"}
VERDICT_COLOURS = {REPRODUCED: SUPPORTED, PARTIAL: INCONCLUSIVE, NOT_REPRODUCED: CONTRADICTED,
                   INCONCLUSIVE: INCONCLUSIVE, PAPER_DISCREPANCY: CONTRADICTED}
NOT_RECORDED = "#bdbdbd"


def _segments(sidecar: Mapping[str, Any] | None) -> tuple[list[str], str]:
    """The colours of one claim's row, left to right, and their hatch ("//": no parts
    recorded, the verdict's colour)."""
    if sidecar is None or not is_result(sidecar):
        return [NOT_RECORDED], ""
    parts = sidecar.get("parts") or []
    if parts:
        return [OUTCOME_COLOURS.get(p["outcome"], NOT_RECORDED) for p in parts], ""
    verdict = VERDICT_COLOURS.get(sidecar.get("verdict", ""), INCONCLUSIVE)
    return [OUTCOME_COLOURS[verdict]], "//"


def claims_by_outcome(sidecars: Mapping[str, Mapping[str, Any]],
                      path: str | os.PathLike) -> Path:
    """Draw every registry claim's parts by outcome and save a small PNG at ``path``."""
    ids = list(CLAIMS)
    fig, ax = plt.subplots(figsize=(7.5, 0.26 * len(ids) + 1.2), dpi=90)
    for row, claim_id in enumerate(ids):
        sidecar = sidecars.get(claim_id)
        colours, hatch = _segments(sidecar)
        width = 1.0 / len(colours)
        for k, colour in enumerate(colours):
            ax.barh(row, width, left=k * width, color=colour, edgecolor="white", height=0.8,
                    hatch=hatch, alpha=0.55 if hatch else 1.0)
        label = ("not recorded" if sidecar is None else "quick run" if not is_result(sidecar)
                 else sidecar.get("verdict", ""))
        ax.text(1.02, row, label, va="center", fontsize=7)
    ax.set_yticks(range(len(ids)), ids, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlim(0, 1.45)
    ax.set_xticks([])
    for side in ("top", "right", "bottom"):
        ax.spines[side].set_visible(False)
    ax.set_title(f"The {len(ids)} claims: each part's outcome, and the verdict", fontsize=9)
    handles = [Patch(color=c, label=o) for o, c in OUTCOME_COLOURS.items()]
    handles.append(Patch(color=NOT_RECORDED, label="not recorded"))
    handles.append(Patch(facecolor="#dddddd", hatch="//", label="no parts (v1): verdict"))
    ax.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.4, -0.12), ncol=3,
              fontsize=7, frameon=False)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90)
    plt.close(fig)
    return write_bytes(path, buffer.getvalue())


@dataclass(frozen=True)
class ForestRow:
    """One row of the forest plot: a part's comparison in units of its δ (None: no interval,
    ``note`` says why)."""

    claim_id: str
    label: str
    outcome: str
    mean: float | None = None
    low: float | None = None
    high: float | None = None
    note: str = ""


def comparisons_of(part: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """A stored part's comparisons (label, numbers) that carry an interval and a δ."""
    return [(label, row) for label, row in (part.get("numbers") or {}).items()
            if isinstance(row, dict) and {"mean", "low", "high"} <= set(row)
            and row.get("smallest_effect")]


def forest_rows(sidecars: Mapping[str, Mapping[str, Any]]) -> list[ForestRow]:
    """Every registry claim's parts as forest rows (effect, interval over |δ|)."""
    rows = []
    for claim_id in CLAIMS:
        sidecar = sidecars.get(claim_id)
        if sidecar is None:
            rows.append(ForestRow(claim_id, "not recorded", "", note="not recorded"))
            continue
        exact = not CLAIMS[claim_id].rests_on_effects
        for part in sidecar.get("parts") or []:
            found = comparisons_of(part)
            if exact or not found:
                rows.append(ForestRow(claim_id, part["name"], part["outcome"], note=(
                    "exact check" if exact else "no interval") + f": {part['outcome']}"))
                continue
            for label, row in found:
                delta = abs(float(row["smallest_effect"]))
                name = part["name"] if label == "difference" or len(found) == 1 else \
                    f"{part['name']}: {label}"
                rows.append(ForestRow(claim_id, name, part["outcome"], row["mean"] / delta,
                                      row["low"] / delta, row["high"] / delta))
    return rows


def forest_plot(sidecars: Mapping[str, Mapping[str, Any]], path: str | os.PathLike) -> Path:
    """Draw :func:`forest_rows` (x on a symmetric log scale, linear within ±3 δ) and save a
    PNG at ``path``."""
    rows = forest_rows(sidecars)
    results = any(is_result(s) for s in sidecars.values())
    fig, ax = plt.subplots(figsize=(9.0, 0.2 * len(rows) + 1.6), dpi=90)
    ax.axvspan(-1, 1, color="#d6d6d6", alpha=0.8, zorder=0.5)   # ±δ, over the claims' shading
    ax.axvline(0, color="#757575", lw=0.8, zorder=1)
    shade, previous = False, None
    for y, row in enumerate(rows):
        if row.claim_id != previous:
            shade, previous = not shade, row.claim_id
            ax.axhline(y - 0.5, color="#bdbdbd", lw=0.5, zorder=1)
        if shade:
            ax.axhspan(y - 0.5, y + 0.5, color="#f5f5f5", zorder=0, lw=0)
        colour = OUTCOME_COLOURS.get(row.outcome, NOT_RECORDED)
        if row.mean is None:
            ax.text(0.01, y, row.note, transform=ax.get_yaxis_transform(), va="center",
                    fontsize=6.5, color=colour if row.outcome else "#757575")
            continue
        ax.plot([row.low, row.high], [y, y], color=colour, lw=1.6, zorder=2)
        ax.plot([row.mean], [y], "o", color=colour, ms=4, zorder=3)
    labels, previous = [], None
    for row in rows:
        labels.append(f"{row.claim_id}  {row.label}" if row.claim_id != previous else row.label)
        previous = row.claim_id
    ax.set_yticks(range(len(rows)), labels, fontsize=6.5)
    ax.set_ylim(len(rows) - 0.5, -0.5)
    ax.set_xscale("symlog", linthresh=3.0)
    ax.margins(x=0.04)
    ax.set_xlabel("mean per-seed effect (difference or log ratio) / δ, with its 95 % interval; "
                  "grey band: ±δ", fontsize=7.5)
    ax.tick_params(axis="x", labelsize=7)
    title = "Every part in units of its smallest effect of interest δ"
    fig.suptitle(title if results else title + " (quick run: a test of the code, not results)",
                 fontsize=9)
    handles = [Patch(color=c, label=o) for o, c in OUTCOME_COLOURS.items()]
    ax.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=5,
              fontsize=7, frameon=False)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return write_bytes(path, buffer.getvalue())
