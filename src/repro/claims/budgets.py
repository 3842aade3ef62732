"""The 2-core time budgets against the results snapshot's run, for README's budgets block.

The per-notebook times are the snapshot's ``run_seconds`` (the run that made ``results/``) and
``slowest_seconds`` (each notebook's slowest known time: a cold run's once one was recorded).
The whole-process totals — a cold and a warm full ``reproduce``, ``make test`` on a cold
cache — are ``make bench`` rows (``build/bench/bench.json``), copied into the snapshot's
``timings`` by :func:`bench_timings` when ``results/`` is written. Until the snapshot is a
full run under registry v2 or later, the block says that no such run has measured them.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from repro.claims.provenance import is_result
from repro.claims.readme import replace_block
from repro.infra.storage import read_json

#: the budgets (2 cores): cold ``make reproduce`` ≤ 60 min, warm ≤ 4 min,
#: ``make test`` on a fresh clone ≤ 5 min
BUDGETS_SECONDS = {"reproduce_standard_cold": 3600.0, "reproduce_standard_warm": 240.0,
                   "make_test_cold_cache": 300.0}
TIMING_NAMES = {"reproduce_standard_cold": "cold standard `make reproduce` (whole process)",
                "reproduce_standard_warm": "warm standard `make reproduce` (whole process)",
                "make_test_cold_cache": "`make test`, cold cache"}
README_BUDGETS_START = "<!-- budgets:start"
README_BUDGETS_END = "<!-- budgets:end -->"


def bench_timings(bench_json: str | os.PathLike) -> dict[str, dict[str, Any]]:
    """The budgeted rows of a ``bench.json`` that succeeded: name → seconds, commit, measured
    ({} if there is no bench)."""
    try:
        rows = read_json(bench_json).get("rows", {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {name: {"seconds": float(row["seconds"]), "commit": row.get("commit"),
                   "measured": row.get("measured")}
            for name, row in rows.items()
            if name in BUDGETS_SECONDS and not row.get("exit_code")}


def run_span_seconds(build_dir: str | os.PathLike,
                     sidecars: Mapping[str, Mapping[str, Any]]) -> float | None:
    """Seconds from the run's start (its ``runs/<run ID>/run.json``) to its last recorded
    claim: the run's wall time but for the notebooks that record no claim after it. None for
    claims of several runs or none recorded by the runner."""
    run_ids = {s.get("run_id") for s in sidecars.values()}
    if len(run_ids) != 1 or not next(iter(run_ids)):
        return None
    try:
        started = read_json(Path(build_dir) / "runs" / str(next(iter(run_ids))) / "run.json")
        start = _dt.datetime.fromisoformat(started["started"])
        last = max(_dt.datetime.fromisoformat(s["recorded_at"]) for s in sidecars.values())
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return round((last - start).total_seconds(), 1)


def snapshot_registry_version(snapshot: Mapping[str, Any]) -> int:
    """The lowest registry version among the snapshot's sidecars (1 when none says)."""
    versions = [int(s.get("registry_version", 1)) for s in snapshot.get("sidecars", {}).values()]
    return min(versions, default=1)


def _snapshot_commit(snapshot: Mapping[str, Any]) -> str | None:
    commits = Counter(s.get("commit") for s in snapshot.get("sidecars", {}).values())
    return commits.most_common(1)[0][0] if commits else None


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s ({seconds / 60:.1f} min)"


def budgets_markdown(snapshot: Mapping[str, Any]) -> str:
    """README's budgets block from a snapshot's ``claims.json``."""
    budgets = ", ".join(f"{TIMING_NAMES[k].split(' (')[0]} ≤ {v / 60:.0f} min"
                        for k, v in BUDGETS_SECONDS.items())
    if not is_result(snapshot) or snapshot_registry_version(snapshot) < 2:
        return (f"Time budgets (2 cores): {budgets}. **No full run under registry v2 or later "
                "exists yet**, so none is measured on one: the committed snapshot is a version 1 "
                "run (its times are in the paragraph below). The next full `make reproduce` "
                "(which refreshes `results/`) writes this block from its run times; `make bench "
                "ARGS=--full` measures the whole-process totals it shows.")
    commit = _snapshot_commit(snapshot)
    lines = [f"Time budgets (2 cores) against the run in `results/` (commit {commit}):", "",
             "| measurement | seconds | budget | |", "|---|---|---|---|"]
    timings = snapshot.get("timings", {})
    for name, budget in BUDGETS_SECONDS.items():
        row = timings.get(name)
        if row is None:
            lines.append(f"| {TIMING_NAMES[name]} | not measured | {budget:.0f} | — |")
            continue
        where = "" if row.get("commit") == commit else f" (commit {row.get('commit')})"
        status = "within" if row["seconds"] <= budget else "**over**"
        lines.append(f"| {TIMING_NAMES[name]}{where} | {_minutes(row['seconds'])} | "
                     f"{budget:.0f} | {status} |")
    span = snapshot.get("run_span_seconds")
    if span is not None:
        lines.append(f"| this run, from its start to its last recorded claim | {_minutes(span)} "
                     "| — | cold or warm: see the provenance |")
    run, slowest = snapshot.get("run_seconds", {}), snapshot.get("slowest_seconds", {})
    lines += ["", "| notebook | this run (s) | slowest known (s) |", "|---|---|---|"]
    lines += [f"| {name} | {run[name]:.0f} | {slowest.get(name, run[name]):.0f} |"
              for name in sorted(run)]
    lines += ["", f"Sum of this run's notebook times: {_minutes(sum(run.values()))} (with "
              "`--jobs` above 1 notebooks overlap, so this is not the whole process's time)."]
    return "\n".join(lines)


def update_readme_budgets(readme: str | os.PathLike, snapshot: Mapping[str, Any]) -> Path:
    """Rewrite README's budgets block from ``snapshot`` (a results ``claims.json``)."""
    return replace_block(readme, README_BUDGETS_START, README_BUDGETS_END,
                         budgets_markdown(snapshot))
