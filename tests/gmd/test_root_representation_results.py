"""Notebook 02's results (``gmd.root_representation_results``): GMD-B1's study and record on
synthetic clips, and the quick scale's B3 control calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import make_context

from repro.claims.result import record
from repro.claims.verdicts import REPRODUCED
from repro.gmd import root_representation as results
from repro.motion.features import FEATURE_DIM


def _clip(frames: int, seed: int) -> np.ndarray:
    """Relative-root features: forward walking (5 cm a frame) with a gentle random turn."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 0.1, (frames, FEATURE_DIM))
    x[:, 0] = 0.01 * np.sin(np.linspace(0, 3, frames)) + rng.normal(0, 0.002, frames)
    x[:, 1] = rng.normal(0.0, 0.003, frames)
    x[:, 2] = 0.05 + rng.normal(0.0, 0.003, frames)
    x[:, 3] = 0.9
    return x


def test_b1_result_records_the_study_and_says_the_real_clip_is_absent(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(results.paths, "humanml3d_sample_dir", lambda: tmp_path / "absent")
    monkeypatch.setattr(results, "load_clips", lambda root, split, min_frames, n: (
        [f"c{k}" for k in range(n)], [_clip(70, k) for k in range(n)]))
    study = results.b1_study(tmp_path, results.Settings.for_scale("quick"))
    assert study.real is None and study.real_measurements is None
    assert len(study.clips) == 8 and study.linearisation.shape == (3,)
    assert "is absent here" in results.round_trip_markdown(study)
    result = results.b1_result(study, figures=[], seed=0)
    assert result.measured["round_trip_max_error"] == study.round_trip_max_error < 1e-12
    assert result.extra["real_clip"] is None
    assert result.headline.endswith("from gap 1 to 54")
    assert record(make_context(tmp_path, scale="standard"), result).verdict == REPRODUCED
    assert "Reading" in results.b1_reading(study)


def test_b3_controls_calibrate_briefly_only_in_a_quick_run() -> None:
    assert results.Settings.for_scale("quick").b3_control_options == {
        "calibration_draws": 1, "rounds": 1, "iterations": 8}
    assert results.Settings.for_scale("standard").b3_control_options == {}
    assert results.Settings.for_scale("paper").b3_control_options == {}
    assert np.isfinite(results.LINEARISATION_DELTAS).all()
