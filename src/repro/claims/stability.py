"""Seed stability: the same notebooks run from two (or more) base seeds, verdict by verdict.

``python -m repro reproduce --seed 3`` (into another build root) gives every notebook a disjoint
list of seeds (``seeds_for``: base, base + 1, ...), so the trained models, the test items and
the sampling noise all change. This module puts the recorded sidecars of such runs side by
side: which verdicts changed (for anything but "reproduced", with each part's outcome), and how
far each of the rule's measurements moved (the mean over a run's seeds, per run). Only full
runs are compared: a quick run is a test of the code.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from repro.claims.ledger import load_sidecars, part_outcomes
from repro.claims.registry import CLAIMS
from repro.infra.storage import write_text


@dataclass(frozen=True)
class StabilityRow:
    """One claim across runs: its verdict and seeds in each, and each measurement's mean."""

    claim_id: str
    verdicts: dict[str, str]
    seeds: dict[str, list[int]]
    means: dict[str, dict[str, float | None]]      # measurement → run → mean over seeds
    parts: dict[str, str] = field(default_factory=dict)  # run → part outcomes (not reproduced)

    @property
    def stable(self) -> bool:
        return len(set(self.verdicts.values())) == 1


def _mean(value: Any) -> float | None:
    """The mean of a measurement (a number, or a per-seed list; None entries ignored)."""
    if isinstance(value, bool):
        return float(value)
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, list | tuple):
        numbers = [float(v) for v in value
                   if isinstance(v, int | float) and not isinstance(v, bool)]
        return float(np.mean(numbers)) if numbers else None
    return None


def flatten_measurements(measured: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested measurements (e.g. a value per λ row) as ``key[row]`` entries."""
    flat: dict[str, Any] = {}
    for key, value in measured.items():
        name = f"{prefix}[{key}]" if prefix else str(key)
        if isinstance(value, Mapping):
            flat.update(flatten_measurements(value, name))
        else:
            flat[name] = value
    return flat


def load_full_sidecars(build_dir: str | os.PathLike) -> dict[str, dict[str, Any]]:
    """The full-run sidecars of ``build_dir``; a quick sidecar or no sidecars raise ValueError."""
    folder = Path(build_dir) / "claims"
    sidecars = load_sidecars(folder)
    if not sidecars:
        raise ValueError(f"no claim sidecars in {folder}: run the notebooks there first")
    quick = sorted(k for k, s in sidecars.items() if s.get("mode") != "full")
    if quick:
        raise ValueError(f"{folder} holds quick-run sidecars {quick}: a quick run is a test of "
                         "the code, not a result, and is never compared")
    return sidecars


def compare_runs(runs: Mapping[str, Mapping[str, dict[str, Any]]]) -> list[StabilityRow]:
    """One ``StabilityRow`` per claim recorded in every run (label → sidecars), in registry
    order."""
    if len(runs) < 2:
        raise ValueError(f"need at least two runs to compare, got {len(runs)}")
    missing = set(not_compared(runs))
    rows = []
    for claim_id in CLAIMS:
        if claim_id in missing:
            continue
        verdicts = {label: s[claim_id]["verdict"] for label, s in runs.items()}
        seeds = {label: list(s[claim_id].get("seeds", [])) for label, s in runs.items()}
        measured = {label: flatten_measurements(s[claim_id]["measured"])
                    for label, s in runs.items()}
        keys = list(next(iter(measured.values())))
        means = {key: {label: _mean(values.get(key)) for label, values in measured.items()}
                 for key in keys}
        parts = {label: part_outcomes(s[claim_id], reasons=False) for label, s in runs.items()}
        rows.append(StabilityRow(claim_id, verdicts, seeds, means, parts))
    return rows


def _number(value: float | None) -> str:
    return "—" if value is None else f"{value:.3g}"


def not_compared(runs: Mapping[str, Mapping[str, dict[str, Any]]]) -> list[str]:
    """Registry claims missing from at least one run (so absent from ``compare_runs``)."""
    return [claim_id for claim_id in CLAIMS
            if not all(claim_id in sidecars for sidecars in runs.values())]


def stability_markdown(rows: list[StabilityRow], labels: list[str],
                       missing: Sequence[str] = ()) -> str:
    """A verdict table (changed verdicts marked) and, per claim, each measurement's means;
    ``missing``: claims not recorded in every run, named as not compared."""
    changed = [r.claim_id for r in rows if not r.stable]
    lines = ["# Seed stability", "",
             f"The same notebooks from {len(labels)} base seeds ({', '.join(labels)}); every "
             "notebook's seed list starts at the base seed, so models, test items and noise all "
             "change. Measurements are means over each run's seeds.", "",
             (f"**Verdicts that changed with the seed: {', '.join(changed)}.**" if changed
              else "**No verdict changed with the seed.**"), ""]
    if missing:
        lines += [f"Not compared (not recorded in every run): {', '.join(missing)}.", ""]
    lines += ["| claim | " + " | ".join(labels) + " | same verdict |",
              "|---|" + "---|" * len(labels) + "---|"]
    for r in rows:
        cells = [r.verdicts[label] + (f" — {r.parts[label]}" if r.parts.get(label) else "")
                 for label in labels]
        lines.append(f"| {r.claim_id} | " + " | ".join(cells)
                     + f" | {'yes' if r.stable else '**no**'} |")
    for r in rows:
        lines += ["", f"## {r.claim_id}{'' if r.stable else ' — verdict changed'}", "",
                  "| measurement | " + " | ".join(f"{label} (seeds {r.seeds[label]})"
                                                  for label in labels) + " |",
                  "|---|" + "---|" * len(labels)]
        for key, per_run in r.means.items():
            lines.append(f"| {key} | " + " | ".join(_number(per_run[label]) for label in labels)
                         + " |")
    return "\n".join(lines) + "\n"


def write_stability(build_dirs: Mapping[str, str | os.PathLike], output: str | os.PathLike) -> Path:
    """Compare the full runs in ``build_dirs`` (label → build folder) and write the markdown
    to ``output`` atomically."""
    runs = {label: load_full_sidecars(folder) for label, folder in build_dirs.items()}
    rows = compare_runs(runs)
    if not rows:
        raise ValueError("no claim is recorded in every run: nothing to compare")
    return write_text(output, stability_markdown(rows, list(build_dirs), not_compared(runs)))
