"""``make bench``: whole-process wall times against the budgets, written to build/bench.

Budgets (2 cores): venv set-up ≤ 3 min; ``make test`` ≤ 5 min; each notebook ≤ 45 s in quick
mode; a standard-scale reproduce ≤ 75 min with a cold cache and ≤ 4 min with a warm one
(``claims.budgets``). Measured here, never asserted in a timed unit test. Every bench ends
with the standard scale's compute plan per notebook (docs/COMPUTE.md, ``run.plan``) against
the newest standard run's measured wall times.

``--full`` times a cold standard reproduce and then a warm one on the cache it filled (about
an hour on 2 cores); ``--warm-cache DIR`` times only the warm one, on the cache of an earlier
standard run. Rows of earlier benches stay in bench.json unless measured again (each row says
when and at which commit it was measured).
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from repro.claims.budgets import BUDGETS_SECONDS as REPORTED_BUDGETS
from repro.infra import paths
from repro.infra.machine import cpu_label
from repro.infra.storage import read_json, write_json
from repro.run.plan import plan_against_measured

#: seconds on 2 cores; the whole-process budgets are defined once in
#: ``claims.budgets`` (the README block compares the run against them)
BUDGETS_SECONDS = {"venv_setup": 180, "notebook_quick": 45,
                   "make_test": REPORTED_BUDGETS["make_test_cold_cache"],
                   "reproduce_standard_cold": REPORTED_BUDGETS["reproduce_standard_cold"],
                   "reproduce_standard_warm": REPORTED_BUDGETS["reproduce_standard_warm"]}


def _timed(command: list[str], env: dict[str, str] | None = None) -> tuple[float, int]:
    start = time.perf_counter()
    completed = subprocess.run(command, cwd=paths.REPO_ROOT, env={**os.environ, **(env or {})},
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - start, completed.returncode


def _commit() -> str | None:
    done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=paths.REPO_ROOT,
                          capture_output=True, text=True, check=False)
    return done.stdout.strip() or None


def run_bench(*, full: bool = False, venv: bool = False, quick: bool = True,
              warm_cache: str | Path | None = None) -> int:
    """Time the budgets; print a table and write ``build/bench/bench.json``.

    ``quick``: unit tests, every notebook in quick mode with a cold cache, ``make test`` with
    a cold cache. ``full``: a cold, then a warm full reproduce. ``warm_cache``: a warm full
    reproduce on that cache (an earlier full run's ``REPRO_CACHE_DIR``).
    """
    if warm_cache is not None and not Path(warm_cache).is_dir():
        raise ValueError(f"--warm-cache {warm_cache}: not a directory (give the cache of an "
                         "earlier full run)")
    python = sys.executable
    rows: dict[str, dict[str, object]] = {}
    commit, cpu = _commit(), cpu_label()

    def measure(name: str, command: list[str], budget: float | None,
                env: dict[str, str] | None = None, **notes: object) -> None:
        print(f"timing {name} ...", flush=True)
        seconds, code = _timed(command, env)
        rows[name] = {"seconds": round(seconds, 1), "budget": budget, "exit_code": code,
                      "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                      "commit": commit, "cpu": cpu, **notes}

    if venv:
        with tempfile.TemporaryDirectory() as tmp:
            target = Path(tmp) / "venv"
            measure("venv_setup", ["bash", "-c",
                                   f"{shutil.which('python3.11') or python} -m venv {target} && "
                                   f"{target}/bin/pip install -q -r requirements-dev.txt"],
                    BUDGETS_SECONDS["venv_setup"])
    if quick:
        _measure_quick(measure, python)
    if warm_cache is not None:
        measure("reproduce_standard_warm", [python, "-m", "repro", "reproduce", "--jobs", "2"],
                BUDGETS_SECONDS["reproduce_standard_warm"],
                {"REPRO_CACHE_DIR": str(Path(warm_cache).resolve())},
                cache=str(Path(warm_cache).resolve()))
    if full:
        with tempfile.TemporaryDirectory() as cold_cache:
            env = {"REPRO_CACHE_DIR": cold_cache}
            measure("reproduce_standard_cold", [python, "-m", "repro", "reproduce", "--jobs", "2"],
                    BUDGETS_SECONDS["reproduce_standard_cold"], env)
            measure("reproduce_standard_warm", [python, "-m", "repro", "reproduce", "--jobs", "2"],
                    BUDGETS_SECONDS["reproduce_standard_warm"], env)
    out = paths.build_root() / "bench" / "bench.json"
    earlier = read_json(out).get("rows", {}) if out.exists() else {}
    rows = {**earlier, **rows}
    print(f"\n{'measurement':48s} {'seconds':>8s} {'budget':>7s}  status")
    for name, row in rows.items():
        budget = row["budget"]
        status = ("FAILED (exit {})".format(row["exit_code"]) if row["exit_code"]
                  else "" if budget is None else "ok" if row["seconds"] <= budget else "OVER")
        print(f"{name:48s} {row['seconds']:8.1f} {budget or '':>7}  {status}"
              + ("" if name not in earlier or row is not earlier[name] else "  (earlier)"))
    kept = read_json(out) if out.is_file() else {}  # e.g. the --training sections
    write_json(out, {**kept, "machine": {"cpus": os.cpu_count(),
                                         "platform": platform.platform(),
                                         "python": platform.python_version()}, "rows": rows})
    print(f"written {out}")
    print_plan_against_measured()
    return 0


def print_plan_against_measured() -> None:
    """docs/COMPUTE.md's per-notebook plan against the newest standard run's wall times (the
    build's report, else the committed ``results/``)."""
    for source in (paths.build_root() / "report" / "claims.json",
                   paths.results_dir() / "claims.json"):
        report = read_json(source) if source.is_file() else {}
        if report.get("scale") == "standard":
            print(f"\nstandard scale, plan (docs/COMPUTE.md) against the run in {source}:")
            print(plan_against_measured(report.get("run_seconds", {})))
            return
    print("\nstandard scale: no standard run measured yet (plan, docs/COMPUTE.md):")
    print(plan_against_measured({}))


def _measure_quick(measure: Callable[..., None], python: str) -> None:
    """Unit tests; every notebook in quick mode, in order, on one cache that starts cold (as
    ``make test`` runs them: a notebook reuses the quick models of the ones before it);
    ``make test`` with a cold cache."""
    from repro.run.runner import available_notebooks

    measure("unit_tests", [python, "-m", "pytest", "-q", "-m", "not notebook"], None)
    with tempfile.TemporaryDirectory() as cold_cache:
        for name in available_notebooks():
            measure(f"notebook_quick_cold:{name}", [python, "-m", "repro", "reproduce",
                                                    "--quick", "--only", name],
                    BUDGETS_SECONDS["notebook_quick"], {"REPRO_CACHE_DIR": cold_cache})
    with tempfile.TemporaryDirectory() as cold_cache:
        measure("make_test_cold_cache", ["make", "test"], BUDGETS_SECONDS["make_test"],
                {"REPRO_CACHE_DIR": cold_cache})
