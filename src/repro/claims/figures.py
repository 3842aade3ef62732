"""The report's figure of every claim by outcome (``figures/claims_by_outcome.png``).

One row per registry claim: its parts as equal segments coloured by outcome (supported,
contradicted, absent, inconclusive, below resolution), the verdict written beside it. A claim
without parts (a version 1 sidecar) is one hatched segment in its verdict's colour
(reproduced green, partially or inconclusive yellow, not reproduced or a discrepancy red);
one not recorded is grey.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
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
