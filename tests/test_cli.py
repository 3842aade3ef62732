"""The command line: clear errors for bad input, and the list of claims."""

from __future__ import annotations

from pathlib import Path

import pytest

from repro.__main__ import main


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


def test_validate_dataset_names_missing_parts(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "new_joint_vecs").mkdir()
    assert main(["validate-dataset", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "texts" in out and "Mean.npy" in out and "train.txt" in out


def test_report_from_sidecars_and_no_quick_snapshot(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from repro.ledger import record_claim

    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path))
    monkeypatch.setenv("REPRO_BUILD_DIR", str(tmp_path))
    assert main(["report"]) == 2  # nothing recorded yet
    record_claim("GMD-A1", {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
                 seeds=[0], quick=False)
    assert main(["report", "--note", "assembled by hand"]) == 0
    text = (tmp_path / "report" / "REPORT.md").read_text()
    assert "**discrepancy in the paper**" in text and "assembled by hand" in text
    monkeypatch.setenv("REPRO_BUILD_DIR", str(tmp_path / "quick"))
    record_claim("GMD-A1", {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5},
                 seeds=[0], quick=True)
    assert main(["report", "--quick", "--snapshot"]) == 2  # a quick run is never a result
    assert (tmp_path / "quick" / "report" / "REPORT.md").is_file()


def test_reproduce_rejects_zero_threads(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reproduce", "--quick", "--only", "00", "--threads", "0"]) == 2
    assert "--threads must be at least 1" in capsys.readouterr().err
