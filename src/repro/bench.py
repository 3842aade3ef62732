"""``make bench``: whole-process wall times against the budgets, written to build/bench.

Budgets (2 cores): venv set-up ≤ 3 min; ``make test`` ≤ 5 min; each notebook ≤ 45 s in quick
mode; full reproduce ≤ 20 min with a cold cache and ≤ 2 min with a warm one. Measured here,
never asserted in a timed unit test.
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import paths
from .storage import write_json

BUDGETS_SECONDS = {"venv_setup": 180, "make_test": 300, "notebook_quick": 45,
                   "reproduce_full_cold": 1200, "reproduce_full_warm": 120}


def _timed(command: list[str], env: dict[str, str] | None = None) -> tuple[float, int]:
    start = time.perf_counter()
    completed = subprocess.run(command, cwd=paths.REPO_ROOT, env={**os.environ, **(env or {})},
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - start, completed.returncode


def run_bench(*, full: bool = False, venv: bool = False) -> int:
    """Time the budgets; print a table and write ``build/bench/bench.json``."""
    python = sys.executable
    rows: dict[str, dict[str, float | int | None]] = {}

    def measure(name: str, command: list[str], budget: float | None,
                env: dict[str, str] | None = None) -> None:
        print(f"timing {name} ...", flush=True)
        seconds, code = _timed(command, env)
        rows[name] = {"seconds": round(seconds, 1), "budget": budget, "exit_code": code}

    if venv:
        with tempfile.TemporaryDirectory() as tmp:
            target = Path(tmp) / "venv"
            measure("venv_setup", ["bash", "-c",
                                   f"{shutil.which('python3.11') or python} -m venv {target} && "
                                   f"{target}/bin/pip install -q -r requirements-dev.txt"],
                    BUDGETS_SECONDS["venv_setup"])
    with tempfile.TemporaryDirectory() as cold_cache:
        cold = {"REPRO_CACHE_DIR": cold_cache}
        measure("unit_tests", [python, "-m", "pytest", "-q", "-m", "not notebook"], None)
        from .runner import available_notebooks

        for name in available_notebooks():
            measure(f"notebook_quick_cold:{name}", [python, "-m", "repro", "reproduce",
                                                    "--quick", "--only", name],
                    BUDGETS_SECONDS["notebook_quick"], cold)
    with tempfile.TemporaryDirectory() as cold_cache:
        measure("make_test_cold_cache", ["make", "test"], BUDGETS_SECONDS["make_test"],
                {"REPRO_CACHE_DIR": cold_cache})
    if full:
        with tempfile.TemporaryDirectory() as cold_cache:
            env = {"REPRO_CACHE_DIR": cold_cache}
            measure("reproduce_full_cold", [python, "-m", "repro", "reproduce", "--jobs", "2"],
                    BUDGETS_SECONDS["reproduce_full_cold"], env)
            measure("reproduce_full_warm", [python, "-m", "repro", "reproduce", "--jobs", "2"],
                    BUDGETS_SECONDS["reproduce_full_warm"], env)
    print(f"\n{'measurement':48s} {'seconds':>8s} {'budget':>7s}  status")
    for name, row in rows.items():
        budget = row["budget"]
        status = ("FAILED (exit {})".format(row["exit_code"]) if row["exit_code"]
                  else "" if budget is None else "ok" if row["seconds"] <= budget else "OVER")
        print(f"{name:48s} {row['seconds']:8.1f} {budget or '':>7}  {status}")
    out = paths.build_root() / "bench" / "bench.json"
    write_json(out, {"machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                                 "python": platform.python_version()}, "rows": rows})
    print(f"written {out}")
    return 0
