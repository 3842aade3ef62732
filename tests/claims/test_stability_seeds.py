"""``stability --base-seeds``: one build folder per base seed, checked to hold that seed's run;
changed claims part by part, every notebook's coverage, overlapping seed lists; ``--run``
runs only the missing base seeds; quick runs only when asked."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import make_context, run_settings

from repro.claims.ledger import record_claim
from repro.claims.registry import CLAIMS
from repro.claims.stability import base_seed_of, seed_build_dir
from repro.run import cli

A3_RUN = run_settings("GMD-A3")

A3 = CLAIMS["GMD-A3"]
A2_MEASURED = {"cosine_x0_share_argmax_fraction": 0.0, "cosine_eps_share_argmax_fraction": 1.0}


@pytest.fixture
def build_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    return tmp_path / "build"


def _run(base_seed: int, *, planted: bool, scale: str = "standard", folder: Path | None = None,
         n_seeds: int = 5) -> Path:
    """A synthetic run from ``base_seed``: GMD-A2 and GMD-A3 recorded, notebook 01 executed."""
    build = folder or seed_build_dir(base_seed, scale=scale)
    ctx = make_context(build, scale=scale, seed=base_seed,
                       run_id=f"20261201T000000.000Z-abc1234-seed{base_seed}-{scale}")
    seeds = [base_seed + i for i in range(n_seeds)]
    rng = np.random.default_rng(base_seed)
    a3 = A3.planted_example(rng) if planted else A3.null_example(rng)
    a3 = {k: v[:n_seeds] if isinstance(v, list) else v for k, v in a3.items()}
    record_claim(ctx, "GMD-A3", a3, settings=A3_RUN, seeds=seeds)
    record_claim(ctx, "GMD-A2", A2_MEASURED, seeds=[base_seed])
    (build / "notebooks").mkdir(parents=True, exist_ok=True)
    (build / "notebooks" / "01_x0_vs_eps.ipynb").write_text("{}", encoding="utf-8")
    return build


def test_two_base_seeds_side_by_side_with_parts_and_coverage(build_root: Path) -> None:
    _run(0, planted=True)
    _run(7, planted=False)
    assert cli.main(["stability", "--base-seeds", "0", "7"]) == 0
    text = (build_root / "report" / "STABILITY.md").read_text(encoding="utf-8")
    assert "| claim | seed 0 | seed 7 | same verdict |" in text
    assert "| GMD-A2 | reproduced | reproduced | yes |" in text
    assert "Verdicts that changed with the seed: GMD-A3." in text
    changed = text[text.index("## Changed verdicts, part by part"):]
    assert changed.startswith("## Changed verdicts, part by part\n\n### GMD-A3: reproduced / ")
    for part in A3.parts:
        assert f"| {part.name} | supported |" in changed
    assert "1 of 9 notebooks executed in every run:" in text
    assert "| 01_x0_vs_eps | every run | 2/4 (GMD-A2, GMD-A3) |" in text
    assert "| 00_stand_in_data | **none** | records no claim |" in text
    assert "| 02_root_representation | **none** | 0/3 (—) |" in text
    assert "Seed lists overlap" not in text


def test_a_folder_holding_another_base_seed_is_refused(build_root: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    _run(0, planted=True)
    _run(0, planted=True, folder=seed_build_dir(7))  # seed 0's run copied into seed 7's folder
    assert cli.main(["stability", "--base-seeds", "0", "7"]) == 2
    err = capsys.readouterr().err
    assert "should hold the run from base seed 7" in err and "GMD-A3 is from base seed 0" in err
    assert base_seed_of({"run_id": "x-seed12-full", "seeds": [3]}) == 12
    assert base_seed_of({"run_id": "", "seeds": [3, 4]}) == 3


def test_overlapping_seed_lists_are_named(build_root: Path) -> None:
    _run(0, planted=True, n_seeds=3)
    _run(1, planted=True, n_seeds=3)
    assert cli.main(["stability", "--base-seeds", "0", "1"]) == 0
    text = (build_root / "report" / "STABILITY.md").read_text(encoding="utf-8")
    assert "**Seed lists overlap** in 1 claim (GMD-A3: 1, 2)" in text
    assert "Base seeds at least 3 apart share no seed." in text


def test_run_executes_only_the_missing_base_seeds(build_root: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    _run(0, planted=True)
    calls = []

    def fake_run(seed: int, *, scale: str, jobs: int, threads: int | None,
                 only: list[str] | None) -> int:
        calls.append((seed, scale, jobs, only))
        _run(seed, planted=True)
        return 0

    monkeypatch.setattr(cli, "run_base_seed", fake_run)
    assert cli.main(["stability", "--base-seeds", "0", "5", "--run", "--jobs", "2",
                     "--only", "01"]) == 0
    assert calls == [(5, "standard", 2, ["01"])]
    assert (build_root / "report" / "STABILITY.md").is_file()
    monkeypatch.setattr(cli, "run_base_seed", lambda seed, **_: 1)
    assert cli.main(["stability", "--base-seeds", "0", "9", "--run"]) == 1


def test_quick_runs_only_when_asked_and_never_into_results(build_root: Path,
                                                           capsys: pytest.CaptureFixture[str],
                                                           ) -> None:
    _run(0, planted=True, scale="quick")
    _run(3, planted=True, scale="quick")
    assert cli.main(["stability", "--base-seeds", "0", "3"]) == 2
    assert "no claim sidecars" in capsys.readouterr().err  # the standard folders are empty
    assert cli.main(["stability", "--base-seeds", "0", "3", "--quick", "--snapshot"]) == 2
    assert cli.main(["stability", "--base-seeds", "0", "3", "--quick"]) == 0
    text = (build_root / "quick" / "report" / "STABILITY.md").read_text(encoding="utf-8")
    assert text.startswith("# Seed stability\n\n**QUICK runs: a test of the machinery")


def test_bad_combinations_are_refused(build_root: Path) -> None:
    assert cli.main(["stability", "--base-seeds", "0", "0"]) == 2
    assert cli.main(["stability", "a", "b", "--run"]) == 2
    assert cli.main(["stability", "a", "--base-seeds", "0", "1"]) == 2
    assert cli.main(["stability", "--base-seeds", "0", "-1"]) == 2


def test_run_base_seed_reproduces_into_the_seed_folder_on_the_shared_cache(
        build_root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import subprocess

    from repro.infra import paths

    seen = {}

    class Done:
        returncode = 0

    def fake_run(command: list[str], *, env: dict[str, str], check: bool) -> Done:
        seen.update(command=command, env=env)
        return Done()

    monkeypatch.delenv("REPRO_CACHE_DIR", raising=False)
    monkeypatch.setattr(subprocess, "run", fake_run)
    assert cli.run_base_seed(5, scale="quick", jobs=2, threads=1, only=["02"]) == 0
    assert seen["command"][1:] == ["-m", "repro", "reproduce", "--seed", "5", "--jobs", "2",
                                   "--threads", "1", "--scale", "quick", "--only", "02"]
    assert seen["env"]["REPRO_BUILD_ROOT"] == str(build_root / "seed5")
    assert seen["env"]["REPRO_CACHE_DIR"] == str(paths.cache_dir()) == str(build_root / "cache")
