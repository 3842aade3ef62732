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
from repro.infra.storage import read_json, write_json

#: the budgets (2 cores): cold ``make reproduce`` ≤ 75 min on the slowest CPU the package is
#: sized for (the AMD EPYC, Zen 4), warm ≤ 4 min, ``make test`` on a fresh clone ≤ 5 min, a
#: quick notebook on a cold cache ≤ 45 s
BUDGETS_SECONDS = {"reproduce_standard_cold": 4500.0, "reproduce_standard_warm": 240.0,
                   "make_test_cold_cache": 300.0, "notebook_quick_cold": 45.0}
TIMING_NAMES = {"reproduce_standard_cold": "cold standard `make reproduce` (the run)",
                "reproduce_standard_warm": "warm standard `make reproduce` (the run)",
                "make_test_cold_cache": "`make test`, cold cache",
                "notebook_quick_cold": "one quick notebook, cold cache"}
#: the bench's per-notebook rows (``run.bench``): ``notebook_quick_cold:<name>``
QUICK_NOTEBOOK_PREFIX = "notebook_quick_cold:"
README_BUDGETS_START = "<!-- budgets:start"
README_BUDGETS_END = "<!-- budgets:end -->"


def bench_timings(bench_json: str | os.PathLike) -> dict[str, dict[str, Any]]:
    """The budgeted rows of a ``bench.json`` that succeeded, the quick notebooks' one by one:
    name → seconds, commit, measured, cpu ({} if there is no bench)."""
    try:
        rows = read_json(bench_json).get("rows", {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {name: {"seconds": float(row["seconds"]), "commit": row.get("commit"),
                   "measured": row.get("measured"), "cpu": row.get("cpu")}
            for name, row in rows.items()
            if (name in BUDGETS_SECONDS or name.startswith(QUICK_NOTEBOOK_PREFIX))
            and not row.get("exit_code")}


def run_timing(*, scale: str, seconds: float, cold: bool, commit: str,
               cpu: str) -> dict[str, dict[str, Any]]:
    """A full ``reproduce``'s own wall time (its start to its report) as a timings row,
    ``reproduce_<scale>_cold`` when it started without a trained model in the cache, else
    ``_warm``; the snapshot it writes shows it beside the bench's rows."""
    return {f"reproduce_{scale}_{'cold' if cold else 'warm'}": {
        "seconds": round(seconds, 1), "commit": commit, "cpu": cpu,
        "measured": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")}}


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
    return f"{seconds / 60:.1f} min" if seconds >= 120 else f"{seconds:.0f} s"


def _where(row: Mapping[str, Any], commit: str | None) -> str:
    """The commit a timing row measured, "this run" for the snapshot's own."""
    return "this run" if row.get("commit") == commit else row.get("commit") or "—"


def _timing_row(label: str, row: Mapping[str, Any] | None, budget: float,
                commit: str | None) -> str:
    if row is None:
        return f"| {label} | not measured | | | {_minutes(budget)} | — |"
    status = "within" if row["seconds"] <= budget else "**over**"
    where = _where(row, commit)
    return (f"| {label} | {_minutes(row['seconds'])} | {row.get('cpu') or '—'} | {where} | "
            f"{_minutes(budget)} | {status} |")


def _quick_notebooks_row(timings: Mapping[str, Any], commit: str | None) -> str:
    """One line for the quick notebooks: the fastest and the slowest, how many over budget."""
    rows = {k.removeprefix(QUICK_NOTEBOOK_PREFIX): v for k, v in timings.items()
            if k.startswith(QUICK_NOTEBOOK_PREFIX)}
    label, budget = TIMING_NAMES["notebook_quick_cold"], BUDGETS_SECONDS["notebook_quick_cold"]
    if not rows:
        return _timing_row(label, None, budget, commit)
    fastest = min(rows, key=lambda k: rows[k]["seconds"])
    slowest = max(rows, key=lambda k: rows[k]["seconds"])
    over = sum(r["seconds"] > budget for r in rows.values())
    first = rows[slowest]
    where = _where(first, commit)
    return (f"| {label} ({len(rows)} notebooks) | {rows[fastest]['seconds']:.0f} s "
            f"({fastest}) to {rows[slowest]['seconds']:.0f} s ({slowest}) | "
            f"{first.get('cpu') or '—'} | {where} | {budget:.0f} s each | "
            + ("within" if not over else f"**{over} over**") + " |")


def _run_id(sidecars: Mapping[str, Mapping[str, Any]]) -> str | None:
    ids = {s.get("run_id") for s in sidecars.values()}
    return next(iter(ids)) if len(ids) == 1 else None


def record_timings(report_dir: str | os.PathLike, timings: Mapping[str, Any]) -> None:
    """Add ``timings`` rows, marked with the run they timed, to a report's ``claims.json``
    (``timings``), which the snapshot carries beside the bench's."""
    path = Path(report_dir) / "claims.json"
    claims = read_json(path)
    run_id = _run_id(claims.get("sidecars", {}))
    claims["timings"] = {**claims.get("timings", {}),
                         **{name: {**row, "run_id": run_id} for name, row in timings.items()}}
    write_json(path, claims)


def kept_timings(claims_json: str | os.PathLike,
                 sidecars: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The timings a rewritten report keeps: those of the run its sidecars come from."""
    try:
        timings = read_json(claims_json).get("timings", {})
    except (OSError, ValueError):
        return {}
    run_id = _run_id(sidecars)
    return {name: row for name, row in timings.items()
            if run_id is not None and row.get("run_id") == run_id}


def budgets_markdown(snapshot: Mapping[str, Any]) -> str:
    """README's measured times against the budgets, from a snapshot's ``claims.json``: the
    run's own wall time (``run_timing``), the bench's rows (``make test``, the quick
    notebooks, a warm run), each with its CPU and commit; then every notebook's time."""
    budgets = ", ".join(f"{TIMING_NAMES[k].split(' (')[0]} ≤ {v / 60:.0f} min"
                        for k, v in BUDGETS_SECONDS.items())
    if not is_result(snapshot) or snapshot_registry_version(snapshot) < 2:
        return (f"Time budgets (2 cores): {budgets}. **No full run under registry v2 or later "
                "exists yet**, so none is measured on one: the committed snapshot is a version 1 "
                "run (its times are in the paragraph below). The next full `make reproduce` "
                "(which refreshes `results/`) writes this block from its run times; `make bench "
                "ARGS=--full` measures the whole-process totals it shows.")
    commit = _snapshot_commit(snapshot)
    timings = snapshot.get("timings", {})
    lines = [f"Measured on 2 cores against the budgets; `results/` is the run of commit "
             f"{commit}; a row of another commit is that row's newest measurement (a cold run, "
             "`make bench`):", "",
             "| measurement | time | CPU | commit | budget | |", "|---|---|---|---|---|---|"]
    for name in ("reproduce_standard_cold", "reproduce_standard_warm", "make_test_cold_cache"):
        lines.append(_timing_row(TIMING_NAMES[name], timings.get(name), BUDGETS_SECONDS[name],
                                 commit))
    lines.append(_quick_notebooks_row(timings, commit))
    span = snapshot.get("run_span_seconds")
    if span is not None:
        lines.append(f"| this run, from its start to its last recorded claim | {_minutes(span)} "
                     "| | this run | | |")
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
