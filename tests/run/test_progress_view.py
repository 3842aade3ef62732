"""What a person sees while a run goes: cell i of N, the stage with its step, an estimate."""

from __future__ import annotations

import io
import json
from pathlib import Path

from repro.run.progress_view import ProgressView, estimate_left_s, notebook_status


def _write(path: Path, record: dict) -> None:
    path.write_text(json.dumps(record))


def test_status_shows_cell_stage_step_and_values(tmp_path: Path) -> None:
    _write(tmp_path / "03_x.cell.json", {"cell": 7, "cells": 18, "source": "train()", "time": 1})
    assert notebook_status("03_x", 133, tmp_path) == "03_x  2m13s  cell 7/18  'train()'"
    _write(tmp_path / "03_x.stage.json", {"stage": "training diffusion model", "step": 412,
                                          "total": 1000, "values": {"loss": 0.03121},
                                          "time": 2})
    assert notebook_status("03_x", 133, tmp_path) == (
        "03_x  2m13s  cell 7/18  training diffusion model 412/1000 loss=0.03121")


def test_estimate_uses_the_slowest_known_times() -> None:
    left, unknown = estimate_left_s(["a", "b"], {"c": 30.0}, {"a": 100, "c": 50}, workers=2)
    assert (left, unknown) == ((100 + 20) / 2, 1)


def test_without_a_terminal_one_line_per_notebook_per_interval(tmp_path: Path) -> None:
    stream = io.StringIO()
    view = ProgressView(progress_dir=tmp_path, total=2, workers=1, known_s={"a": 60.0},
                        stream=stream, terminal=False, interval_s=0)
    view.update(["b"], {"a": 10.0}, done=0)
    lines = stream.getvalue().splitlines()
    assert lines[0] == "[running] a  10s"
    assert lines[1].startswith("[overall] 0/2 done, 1 running, about 50s left")
    view.interval_s = 3600
    view.update(["b"], {"a": 11.0}, done=0)
    assert len(stream.getvalue().splitlines()) == 2               # not yet due


def test_in_a_terminal_the_block_is_redrawn_in_place(tmp_path: Path) -> None:
    stream = io.StringIO()
    view = ProgressView(progress_dir=tmp_path, total=1, workers=1, known_s={},
                        stream=stream, terminal=True)
    view.update([], {"a": 1.0}, done=0)
    view.update([], {"a": 2.0}, done=0)
    assert "\x1b[2F\x1b[J" in stream.getvalue()          # moved up over the two lines drawn
    view.log("[1/1] a: ok in 2.0 s")
    assert stream.getvalue().endswith("\x1b[2F\x1b[J[1/1] a: ok in 2.0 s\n")
