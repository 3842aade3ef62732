"""The power look of issue #32 (docs/COMPUTE.md §12): for every comparison of every part of a
standard run's claims — the experiment and its positive control — the smallest effect of
interest δ, the run's own per-seed spread σ, the minimum detectable effect (MDE) at the run's
seeds (80 % power, one-sided α = 0.025/k over the claim's k parts, ``claims.power``), and the
seeds the same spread would need for MDE ≤ δ. A comparison whose MDE is above δ cannot be
decided at this seed count whatever its models do; "seeds for δ" says what would decide it
(more seeds of the same cheap models, or the paper scale). Reads the report's claims.json::

    python scripts/power_look.py results/claims.json > /tmp/power.md
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from repro.claims.power import ALPHA, minimum_detectable_effect

MAX_SEEDS = 40


def seeds_for(delta: float, spread: float, alpha: float) -> int | None:
    """The smallest n ≥ 2 with MDE(n, σ) ≤ δ (None: more than ``MAX_SEEDS``)."""
    for n in range(2, MAX_SEEDS + 1):
        if minimum_detectable_effect(n, spread, alpha=alpha) <= delta:
            return n
    return None


def comparisons(part: dict) -> list[tuple[str, dict]]:
    """The (label, numbers) of a part's paired comparisons (those with a spread and δ)."""
    numbers = part.get("numbers") or {}
    return [(label if label != "difference" else "", value) for label, value in numbers.items()
            if isinstance(value, dict) and {"spread", "smallest_effect", "n"} <= value.keys()]


def rows_of(claim: dict) -> list[str]:
    parts = claim.get("parts") or []
    k = max(len(parts), 1)
    alpha = ALPHA / k
    rows = []
    sources = [("experiment", parts)]
    positive = (claim.get("controls") or {}).get("positive") or {}
    sources.append((f"positive control ({positive.get('status', '—')})",
                    positive.get("parts") or []))
    for source, source_parts in sources:
        for part in source_parts:
            for label, v in comparisons(part):
                delta, spread, n = float(v["smallest_effect"]), float(v["spread"]), int(v["n"])
                mde = minimum_detectable_effect(n, spread, alpha=alpha)
                need = seeds_for(delta, spread, alpha)
                ratio = mde / delta if delta > 0 else math.inf
                name = part["name"] + (f" [{label}]" if label else "")
                rows.append(f"| {claim['id']} | {source} | {name} | {part.get('outcome', '—')} "
                            f"| {delta:.3g} | {spread:.3g} | {mde:.3g} | {ratio:.2g} | "
                            f"{'> ' + str(MAX_SEEDS) if need is None else need} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("claims", type=Path, help="a report's claims.json (results/claims.json)")
    args = parser.parse_args()
    report = json.loads(args.claims.read_text(encoding="utf-8"))
    print(f"scale: {report.get('scale')}\n")
    print("| claim | source | part [comparison] | outcome | δ | σ (per seed) | MDE | MDE/δ "
          "| seeds for δ |")
    print("|---|---|---|---|---|---|---|---|---|")
    for claim in report["sidecars"].values():
        for row in rows_of(claim):
            print(row)


if __name__ == "__main__":
    main()
