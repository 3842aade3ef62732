"""The command line: clear errors for bad input, and the list of claims."""

from __future__ import annotations

from pathlib import Path

import pytest

from repro.run.cli import main


def test_list_prints_every_claim(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "GMD-A1" in out and "EMG-9" in out


def test_reproduce_unknown_target_is_named(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "--quick", "--only", "XYZ-1"]) == 2
    assert "unknown notebook or claim ID 'XYZ-1'" in capsys.readouterr().err


def test_reproduce_bad_parameter_syntax() -> None:
    with pytest.raises(SystemExit):
        main(["reproduce", "--quick", "-p", "no_equals_sign"])


def test_validate_dataset_missing_folder(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate-dataset", str(tmp_path / "absent")]) == 1
    assert "dataset folder not found" in capsys.readouterr().out


def test_validate_dataset_names_a_file_given_as_the_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "Mean.npy").write_bytes(b"")
    assert main(["validate-dataset", str(tmp_path / "Mean.npy")]) == 1
    out = capsys.readouterr().out
    assert "is a file, not a folder" in out and "not found" not in out


def test_validate_dataset_names_missing_parts(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "new_joint_vecs").mkdir()
    assert main(["validate-dataset", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "texts" in out and "Mean.npy" in out and "train.txt" in out


def test_validate_dataset_says_notebook_by_notebook_whether_it_uses_the_stubs(
        capsys: pytest.CaptureFixture[str]) -> None:
    from repro.infra.paths import data_stubs_dir

    stubs = str(data_stubs_dir())
    assert main(["validate-dataset", stubs, "--scale", "quick"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "layout valid" in lines[0]
    assert any(line.split() == ["uses", "it", "01_x0_vs_eps"] for line in lines)
    assert any(line.split() == ["uses", "it", "00_stand_in_data"] for line in lines)
    assert any(line.split() == ["cannot", "04_energy_contour_maps"] for line in lines)
    assert main(["validate-dataset", stubs, "--scale", "quick", "--notebook", "01",
                 "--notebook", "GMD-F1"]) == 0
    assert main(["validate-dataset", stubs, "--scale", "quick", "--notebook", "04"]) == 1
    assert "windows of 64 frames" in capsys.readouterr().out
    assert main(["validate-dataset", stubs, "--notebook", "XYZ"]) == 2


def test_report_from_sidecars_and_no_quick_snapshot(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from conftest import make_context

    from repro.claims.ledger import record_claim
    from repro.infra.storage import read_json

    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path))
    assert main(["report"]) == 2  # nothing recorded yet
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}, seeds=[0])
    assert main(["report", "--note", "assembled by hand"]) == 0
    text = (tmp_path / "report" / "REPORT.md").read_text()
    assert "**discrepancy in the paper**" in text and "assembled by hand" in text
    claims = tmp_path / "report" / "claims.json"
    claims.write_text(claims.read_text().replace('"run_seconds": {}',
                                                 '"run_seconds": {"01_x0_vs_eps": 230.5}'))
    assert main(["report", "--note", "again"]) == 0          # run times of the last run kept
    assert "| 01_x0_vs_eps | 230.5 |" in (tmp_path / "report" / "REPORT.md").read_text()
    assert read_json(claims)["run_seconds"] == {"01_x0_vs_eps": 230.5}
    assert read_json(claims)["slowest_seconds"] == {"01_x0_vs_eps": 230.5}
    record_claim(make_context(tmp_path / "quick"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}, seeds=[0])
    assert main(["report", "--quick", "--snapshot"]) == 2  # a quick run is never a result
    assert not (tmp_path / "quick" / "report").exists()      # refused before any work


@pytest.mark.parametrize("scale", ["quick", "paper"])
def test_reproduce_snapshot_of_another_scale_is_refused_before_any_work(
        scale: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from repro.run import runner

    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path))
    monkeypatch.setattr(runner, "run_notebooks", lambda *a, **k: pytest.fail("work started"))
    assert main(["reproduce", "--scale", scale, "--only", "00", "--snapshot"]) == 2
    err = capsys.readouterr().err
    assert "--snapshot refreshes results/" in err and f"the {scale} scale" in err
    assert list(tmp_path.iterdir()) == []


def test_reproduce_rejects_zero_threads(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "--quick", "--only", "00", "--threads", "0"]) == 2
    assert "--threads must be at least 1" in capsys.readouterr().err


def test_bench_warm_cache_is_checked_and_rows_of_earlier_benches_stay(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from repro.infra.storage import read_json
    from repro.run import bench

    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    assert main(["bench", "--no-quick", "--warm-cache", str(tmp_path / "absent")]) == 2
    err = capsys.readouterr().err
    assert "--warm-cache" in err and "absent: not a directory" in err
    timed: list[dict[str, str] | None] = []

    def fake_timed(command: list[str], env: dict[str, str] | None = None) -> tuple[float, int]:
        timed.append(env)
        return 3.0, 0

    monkeypatch.setattr(bench, "_timed", fake_timed)
    (tmp_path / "cache").mkdir()
    out = tmp_path / "build" / "bench" / "bench.json"
    out.parent.mkdir(parents=True)
    out.write_text('{"rows": {"make_test_cold_cache": {"seconds": 176.0, "budget": 300, '
                   '"exit_code": 0}}}')
    assert bench.run_bench(quick=False, warm_cache=tmp_path / "cache") == 0
    rows = read_json(out)["rows"]
    assert rows["make_test_cold_cache"]["seconds"] == 176.0         # kept from the earlier bench
    assert rows["reproduce_standard_warm"]["seconds"] == 3.0
    assert rows["reproduce_standard_warm"]["cache"] == str((tmp_path / "cache").resolve())
    assert timed == [{"REPRO_CACHE_DIR": str((tmp_path / "cache").resolve())}]


def test_the_scale_is_one_of_three_and_quick_is_its_shorthand(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "--quick", "--scale", "paper", "--only", "00"]) == 2
    assert "--quick and --scale paper disagree" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse names the three scales
        main(["reproduce", "--scale", "full"])
    assert "invalid choice: 'full'" in capsys.readouterr().err
    assert main(["report", "--scale", "paper", "--quick"]) == 2


def test_make_lab_takes_arguments_and_runs_as_root() -> None:
    """Jupyter refuses root without --allow-root (containers, CI images): ``make lab`` adds it
    for root and passes ``ARGS`` on."""
    import os
    import shutil
    import subprocess

    from repro.infra import paths

    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    dry = subprocess.run(["make", "-n", "lab",
                          "ARGS=--no-browser --port 8899"], cwd=paths.REPO_ROOT,
                         capture_output=True, text=True, check=True).stdout
    [command] = [line for line in dry.splitlines() if "jupyter lab" in line]
    assert command.endswith("--no-browser --port 8899")
    assert ("--allow-root" in command) == (os.getuid() == 0)
