"""README's budgets block: the budgets against the snapshot's run, written from
results/claims.json (and the ``make bench`` totals); until a v2+ full run exists it says so."""

from __future__ import annotations

import json
from pathlib import Path

from repro.claims.budgets import (
    bench_timings,
    budgets_markdown,
    run_span_seconds,
    update_readme_budgets,
)
from repro.infra import paths
from repro.infra.storage import read_json


def test_readme_budgets_block_matches_the_results_snapshot() -> None:
    snapshot = read_json(paths.results_dir() / "claims.json")
    readme = (paths.REPO_ROOT / "README.md").read_text(encoding="utf-8")
    assert budgets_markdown(snapshot) in readme


def _snapshot(version: int, **extra: object) -> dict:
    sidecar = {"registry_version": version, "commit": "abc1234"}
    return {"mode": "full", "sidecars": {"GMD-A1": sidecar, "EMG-1": sidecar},
            "run_seconds": {"01_x0_vs_eps": 176.3, "00_stand_in_data": 19.5},
            "slowest_seconds": {"01_x0_vs_eps": 1292.0, "00_stand_in_data": 19.5}, **extra}


def test_a_version_1_snapshot_says_no_v2_run_exists() -> None:
    text = budgets_markdown(_snapshot(1))
    assert "**No full run under registry v2 or later exists yet**" in text
    assert "cold standard `make reproduce` ≤ 75 min, warm standard `make reproduce` ≤ 4 min" in text
    assert "|" not in text  # no table of times that were not measured on such a run
    assert "No full run" in budgets_markdown({**_snapshot(3), "mode": "quick"})


def test_a_v3_snapshot_shows_totals_against_budgets_and_per_notebook_times() -> None:
    cpu = "Intel Xeon, 2 cores, AMX-BF16"
    timings = {"reproduce_standard_cold": {"seconds": 4600.0, "commit": "abc1234", "cpu": cpu},
               "reproduce_standard_warm": {"seconds": 200.0, "commit": "0ld0ld0"},
               "notebook_quick_cold:00_stand_in_data": {"seconds": 20.0, "commit": "0ld0ld0",
                                                        "cpu": cpu},
               "notebook_quick_cold:01_x0_vs_eps": {"seconds": 146.0, "commit": "0ld0ld0",
                                                    "cpu": cpu}}
    text = budgets_markdown(_snapshot(3, timings=timings, run_span_seconds=3990.0))
    assert "`results/` is the run of commit abc1234" in text
    assert (f"| cold standard `make reproduce` (the run) | 76.7 min | {cpu} | this run | "
            "75.0 min | **over** |") in text
    assert ("| warm standard `make reproduce` (the run) | 3.3 min | — | 0ld0ld0 | 4.0 min | "
            "within |") in text
    assert "| `make test`, cold cache | not measured | | | 5.0 min | — |" in text
    assert (f"| one quick notebook, cold cache (2 notebooks) | 20 s (00_stand_in_data) to "
            f"146 s (01_x0_vs_eps) | {cpu} | 0ld0ld0 | 45 s each | **1 over** |") in text
    assert "| this run, from its start to its last recorded claim | 66.5 min |" in text
    assert "| 00_stand_in_data | 20 | 20 |\n| 01_x0_vs_eps | 176 | 1292 |" in text
    assert "Sum of this run's notebook times: 3.3 min" in text


def test_the_run_records_its_own_time_cold_or_warm(tmp_path: Path) -> None:
    from repro.claims.budgets import record_timings, run_timing

    (tmp_path / "claims.json").write_text(json.dumps({"scale": "standard"}), encoding="utf-8")
    record_timings(tmp_path, run_timing(scale="standard", seconds=1466.04, cold=True,
                                        commit="abc1234", cpu="X"))
    record_timings(tmp_path, run_timing(scale="standard", seconds=90.0, cold=False,
                                        commit="abc1234", cpu="X"))
    timings = read_json(tmp_path / "claims.json")["timings"]
    assert timings["reproduce_standard_cold"]["seconds"] == 1466.0
    assert timings["reproduce_standard_warm"]["cpu"] == "X"


def test_a_rewritten_report_keeps_only_its_own_runs_timings(tmp_path: Path) -> None:
    from repro.claims.budgets import kept_timings, record_timings, run_timing

    sidecars = {"GMD-A1": {"run_id": "r1"}, "EMG-1": {"run_id": "r1"}}
    (tmp_path / "claims.json").write_text(json.dumps({"sidecars": sidecars}), encoding="utf-8")
    record_timings(tmp_path, run_timing(scale="standard", seconds=60.0, cold=True,
                                        commit="c", cpu="X"))
    assert set(kept_timings(tmp_path / "claims.json", sidecars)) == {"reproduce_standard_cold"}
    assert kept_timings(tmp_path / "claims.json", {"GMD-A1": {"run_id": "r2"}}) == {}
    assert kept_timings(tmp_path / "absent.json", sidecars) == {}


def test_bench_rows_that_failed_or_are_not_budgeted_are_left_out(tmp_path: Path) -> None:
    bench = tmp_path / "bench.json"
    bench.write_text(json.dumps({"rows": {
        "reproduce_standard_cold": {"seconds": 3000.04, "exit_code": 0, "commit": "c1",
                                "measured": "2026-12-01 10:00 UTC"},
        "reproduce_standard_warm": {"seconds": 100.0, "exit_code": 1, "commit": "c1"},
        "unit_tests": {"seconds": 50.0, "exit_code": 0}}}), encoding="utf-8")
    assert bench_timings(bench) == {"reproduce_standard_cold": {
        "seconds": 3000.04, "commit": "c1", "measured": "2026-12-01 10:00 UTC", "cpu": None}}
    assert bench_timings(tmp_path / "missing.json") == {}


def test_run_span_reads_the_run_start_and_the_last_claim(tmp_path: Path) -> None:
    run_id = "20261201T100000.000Z-abc-seed0-full"
    (tmp_path / "runs" / run_id).mkdir(parents=True)
    (tmp_path / "runs" / run_id / "run.json").write_text(
        json.dumps({"started": "2026-12-01T10:00:00+00:00"}), encoding="utf-8")
    sidecars = {"A": {"run_id": run_id, "recorded_at": "2026-12-01T10:30:00+00:00"},
                "B": {"run_id": run_id, "recorded_at": "2026-12-01T10:50:30+00:00"}}
    assert run_span_seconds(tmp_path, sidecars) == 3030.0
    assert run_span_seconds(tmp_path, {**sidecars, "C": {"run_id": "other"}}) is None
    assert run_span_seconds(tmp_path, {"A": {"run_id": ""}}) is None


def test_update_rewrites_only_the_marked_block(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text("a\n<!-- budgets:start x -->\n| stale |\n<!-- budgets:end -->\nb\n",
                      encoding="utf-8")
    update_readme_budgets(readme, _snapshot(1))
    text = readme.read_text(encoding="utf-8")
    assert "| stale |" not in text
    assert text.startswith("a\n<!-- budgets:start x -->\nTime budgets (2 cores)")
    assert text.endswith("\n<!-- budgets:end -->\nb\n")
