"""Seed stability: the same notebooks run from two (or more) base seeds, verdict by verdict.

``python -m repro reproduce --seed 3`` (into another build root) gives every notebook the seed
list base, base + 1, …, so the trained models, the test items and the sampling noise all
change. ``python -m repro stability --base-seeds 0 3`` reads (``--run``: first runs) one build
folder per base seed (:func:`seed_build_dir`: ``build/`` for 0, ``build/seed<N>/`` otherwise),
checks that each holds the run of its base seed, and writes STABILITY.md: the verdicts side
by side, which changed, each changed claim's parts side by side, every notebook's coverage
(executed in every run, its claims compared), seed lists that overlap between runs (such runs
are not independent), and how far each of the rule's measurements moved (the mean over a
run's seeds, per run). Runs of one scale are compared (``scale``, default "standard": the
snapshot's); quick runs only as a test of the machinery, headed as such.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from repro.claims.ledger import load_sidecars, part_outcomes
from repro.claims.registry import CLAIMS, claims_for_notebook
from repro.infra import paths
from repro.infra.context import check_scale
from repro.infra.storage import write_text

_RUN_SEED = re.compile(r"-seed(\d+)-(?:quick|standard|paper|full)$")


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


def load_scale_sidecars(build_dir: str | os.PathLike, *, scale: str = "standard",
                        ) -> dict[str, dict[str, Any]]:
    """The sidecars of ``build_dir``, every one of a ``scale`` run; a sidecar of another
    scale or no sidecars raise ValueError."""
    check_scale(scale)
    folder = Path(build_dir) / "claims"
    sidecars = load_sidecars(folder)
    if not sidecars:
        raise ValueError(f"no claim sidecars in {folder}: run the notebooks there first")
    wrong = sorted(k for k, s in sidecars.items() if s.get("scale") != scale)
    if wrong:
        raise ValueError(f"{folder} holds sidecars {wrong} of another scale than {scale} (a "
                         "quick run is a test of the code, never compared with a result; "
                         "runs of different scales are different experiments)")
    return sidecars


def seed_build_dir(base_seed: int, *, scale: str = "standard") -> Path:
    """The build folder of the ``scale`` run from ``base_seed``: below ``build/`` for 0 (the
    default ``reproduce``), below ``build/seed<N>/`` otherwise (``REPRO_BUILD_ROOT`` of that
    run); the standard scale's at that root, the others in ``quick/`` and ``paper/``."""
    check_scale(scale)
    if base_seed < 0:
        raise ValueError(f"base seeds are ≥ 0, got {base_seed}")
    root = paths.build_root() if base_seed == 0 else paths.build_root() / f"seed{base_seed}"
    return root if scale == "standard" else root / scale


def base_seed_of(sidecar: Mapping[str, Any]) -> int | None:
    """The base seed a sidecar was recorded from: its run ID's ``-seed<N>-``, else the first
    of its seeds (a notebook's seeds start at the base seed); None if neither says."""
    found = _RUN_SEED.search(sidecar.get("run_id") or "")
    if found:
        return int(found[1])
    seeds = sidecar.get("seeds") or []
    return int(seeds[0]) if seeds else None


def check_base_seed(sidecars: Mapping[str, Mapping[str, Any]], base_seed: int,
                    folder: str | os.PathLike) -> None:
    """Raise ValueError unless every sidecar in ``folder`` comes from ``base_seed``."""
    wrong = {claim_id: base_seed_of(s) for claim_id, s in sidecars.items()
             if base_seed_of(s) not in (None, base_seed)}
    if wrong:
        raise ValueError(f"{folder} should hold the run from base seed {base_seed}, but "
                         + ", ".join(f"{c} is from base seed {s}" for c, s in wrong.items())
                         + f": rerun it (REPRO_BUILD_ROOT={Path(folder)} python -m repro "
                         f"reproduce --seed {base_seed})")


def seed_overlaps(runs: Mapping[str, Mapping[str, dict[str, Any]]]) -> dict[str, list[int]]:
    """Claim → the seeds that two or more runs share (only claims with an overlap)."""
    overlaps: dict[str, list[int]] = {}
    for claim_id in CLAIMS:
        lists = [set(s[claim_id].get("seeds", [])) for s in runs.values() if claim_id in s]
        shared = sorted({seed for i, a in enumerate(lists) for b in lists[i + 1:]
                         for seed in a & b})
        if shared:
            overlaps[claim_id] = shared
    return overlaps


def notebook_coverage(build_dirs: Mapping[str, str | os.PathLike],
                      runs: Mapping[str, Mapping[str, dict[str, Any]]]) -> list[list[str]]:
    """Per notebook in ``notebooks/``: executed in every run (its published executed notebook
    in each build folder's ``notebooks/``), and its claims compared (recorded in every run)."""
    rows = []
    for notebook in sorted(p.stem for p in paths.notebooks_dir().glob("[0-9][0-9]_*.ipynb")):
        executed = [label for label, folder in build_dirs.items()
                    if (Path(folder) / "notebooks" / f"{notebook}.ipynb").is_file()]
        ids = [c.id for c in claims_for_notebook(notebook)]
        compared = [c for c in ids if all(c in s for s in runs.values())]
        rows.append([notebook, "every run" if len(executed) == len(build_dirs)
                     else f"**{', '.join(executed) or 'none'}**",
                     (f"{len(compared)}/{len(ids)} ({', '.join(compared) or '—'})" if ids
                      else "records no claim")])
    return rows


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


def changed_parts_markdown(rows: list[StabilityRow],
                           runs: Mapping[str, Mapping[str, dict[str, Any]]]) -> list[str]:
    """For every claim whose verdict changed: each part's outcome per run, side by side."""
    labels = list(runs)
    lines = []
    for r in rows:
        if r.stable:
            continue
        outcomes = {label: {p["name"]: p["outcome"] for p in runs[label][r.claim_id].get(
            "parts", [])} for label in labels}
        names = list(dict.fromkeys(n for label in labels for n in outcomes[label]))
        lines += ["", f"### {r.claim_id}: " + " / ".join(r.verdicts[label] for label in labels),
                  "", "| part | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
        lines += [f"| {name} | " + " | ".join(outcomes[label].get(name, "—") for label in labels)
                  + " |" for name in names]
    return (["", "## Changed verdicts, part by part"] + lines) if lines else []


def stability_markdown(rows: list[StabilityRow], labels: list[str],
                       missing: Sequence[str] = (), *,
                       runs: Mapping[str, Mapping[str, dict[str, Any]]] | None = None,
                       coverage: Sequence[Sequence[str]] = (), scale: str = "standard") -> str:
    """A verdict table (changed verdicts marked), the changed claims' parts side by side
    (``runs``), every notebook's coverage, overlapping seeds, and per claim each measurement's
    means; ``missing``: claims not recorded in every run, named as not compared."""
    changed = [r.claim_id for r in rows if not r.stable]
    lines = ["# Seed stability", ""]
    if scale == "quick":
        lines += ["**QUICK runs: a test of the machinery; no verdict here is a result.**", ""]
    else:
        lines += [f"Runs of the {scale} scale.", ""]
    lines += [f"The same notebooks from {len(labels)} base seeds ({', '.join(labels)}); every "
              "notebook's seed list starts at the base seed, so models, test items and noise "
              "all change. Measurements are means over each run's seeds.", "",
              (f"**Verdicts that changed with the seed: {', '.join(changed)}.**" if changed
               else "**No verdict changed with the seed.**"), ""]
    if missing:
        lines += [f"Not compared (not recorded in every run): {', '.join(missing)}.", ""]
    overlaps = seed_overlaps(runs or {})
    if overlaps:
        longest = max(len(s) for r in rows for s in r.seeds.values())
        lines += [f"**Seed lists overlap** in {len(overlaps)} claim"
                  f"{'' if len(overlaps) == 1 else 's'} ("
                  + "; ".join(f"{c}: {', '.join(map(str, s))}" for c, s in overlaps.items())
                  + "): those runs share models, items or noise, so they are not independent "
                  f"repeats. Base seeds at least {longest} apart share no seed.", ""]
    if coverage:
        everywhere = sum(row[1] == "every run" for row in coverage)
        lines += [f"{everywhere} of {len(coverage)} notebooks executed in every run:", "",
                  "| notebook | executed | claims compared |", "|---|---|---|"]
        lines += [f"| {' | '.join(row)} |" for row in coverage]
        lines.append("")
    lines += ["| claim | " + " | ".join(labels) + " | same verdict |",
              "|---|" + "---|" * len(labels) + "---|"]
    for r in rows:
        cells = [r.verdicts[label] + (f" — {r.parts[label]}" if r.parts.get(label) else "")
                 for label in labels]
        lines.append(f"| {r.claim_id} | " + " | ".join(cells)
                     + f" | {'yes' if r.stable else '**no**'} |")
    lines += changed_parts_markdown(rows, runs or {})
    lines += ["", "## Measurements per claim"]
    for r in rows:
        lines += ["", f"### {r.claim_id}{'' if r.stable else ' — verdict changed'}", "",
                  "| measurement | " + " | ".join(f"{label} (seeds {r.seeds[label]})"
                                                  for label in labels) + " |",
                  "|---|" + "---|" * len(labels)]
        for key, per_run in r.means.items():
            lines.append(f"| {key} | " + " | ".join(_number(per_run[label]) for label in labels)
                         + " |")
    return "\n".join(lines) + "\n"


def write_stability(build_dirs: Mapping[str, str | os.PathLike], output: str | os.PathLike,
                    *, base_seeds: Mapping[str, int] | None = None,
                    scale: str = "standard") -> Path:
    """Compare the runs in ``build_dirs`` (label → build folder; runs of ``scale``)
    and write the markdown to ``output`` atomically. ``base_seeds`` (label → seed): each
    folder must hold the run of its seed."""
    runs = {label: load_scale_sidecars(folder, scale=scale)
            for label, folder in build_dirs.items()}
    for label, seed in (base_seeds or {}).items():
        check_base_seed(runs[label], seed, build_dirs[label])
    rows = compare_runs(runs)
    if not rows:
        raise ValueError("no claim is recorded in every run: nothing to compare")
    return write_text(output, stability_markdown(
        rows, list(build_dirs), not_compared(runs), runs=runs,
        coverage=notebook_coverage(build_dirs, runs), scale=scale))
