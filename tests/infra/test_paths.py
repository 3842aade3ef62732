"""Paths written for a reader elsewhere: ``paths.portable`` leaves no absolute location of
the machine that ran a run (rendered notebooks, the results/ snapshot)."""

from __future__ import annotations

from pathlib import Path

import pytest

from repro.infra import paths


def test_paths_in_the_clone_become_relative_to_it() -> None:
    root = paths.REPO_ROOT
    text = (f'build_dir = "{root}/build/runs/ID/00_stand_in_data"\n'
            f"dataset: {root}/build/cache/datasets/7a15: no problems\n"
            f"{root.parent / 'shared'}/humanml3d_sample not found; the clone: {root}")
    assert paths.portable(text) == (
        'build_dir = "build/runs/ID/00_stand_in_data"\n'
        "dataset: build/cache/datasets/7a15: no problems\n"
        "../shared/humanml3d_sample not found; the clone: .")


def test_moved_folders_are_written_as_their_variable(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "b"))
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "models"))
    text = f"{tmp_path}/b/quick/runs/ID and {tmp_path}/models/gmd and {tmp_path}/bc"
    assert paths.portable(text) == (f"$REPRO_BUILD_ROOT/quick/runs/ID and "
                                    f"$REPRO_CACHE_DIR/gmd and {tmp_path}/bc")


def test_a_longer_name_sharing_the_prefix_is_left_alone() -> None:
    other = f"{paths.REPO_ROOT}2/build and /x{paths.REPO_ROOT}"
    assert paths.portable(other) == other
