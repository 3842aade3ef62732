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
