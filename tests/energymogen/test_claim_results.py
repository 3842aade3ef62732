"""What the EnergyMoGen experiments return (``energy_contour_maps``, ``latent_count``,
``sef_ablation``): a ClaimResult with every measurement the registered rule reads, its
controls' calibration kept beside, and the notebooks' summary lines."""

from __future__ import annotations

from pathlib import Path

from conftest import make_context

from repro.claims.ledger import load_sidecars
from repro.claims.registry import get_claim
from repro.claims.result import Controls, record
from repro.energymogen.energy_contour_maps.emg9 import (
    emg9_result,
    fid_draws_markdown,
    fid_fixed_cases,
    fid_formula_errors,
)
from repro.energymogen.latent_count.emg7 import LatentCountSettings, emg7_result
from repro.energymogen.sef_ablation.threes import summary_line


def test_emg9_is_recorded_with_every_measurement_its_rule_reads(tmp_path: Path) -> None:
    fid_check, fixed = fid_formula_errors(0), fid_fixed_cases()
    result = emg9_result(fid_check, fixed, 0)
    assert set(get_claim("EMG-9").measurements) <= set(result.measured)
    record(make_context(tmp_path), result)
    sidecar = load_sidecars(tmp_path / "claims")["EMG-9"]
    assert sidecar["extra"]["fixed_cases"] == fixed["cases"]
    assert len(sidecar["extra"]["draws"]) == 5
    assert fid_draws_markdown(fid_check).count("\n") == 6     # header, rule, five draws


def _latent_count_results(counts: tuple[int, ...]) -> dict:
    parts = {part: {str(n): {"mpjpe": [0.01 * n, 0.014 * n], "fid": [0.1 * n, 0.14 * n]}
                    for n in counts} for part in ("reconstruction", "generation")}
    return {**parts, "real": {"fid": [0.0, 0.0]}, "seconds": {str(n): [1.0, 1.0] for n in counts},
            "training": {str(n): [{}, {}] for n in counts}}


def test_emg7_names_the_counts_a_scale_does_not_run_and_keeps_the_calibration() -> None:
    settings = LatentCountSettings.for_scale("quick")
    controls = Controls(null={}, positive={}, planted={"offset_mean_m": 0.05})
    results = _latent_count_results(settings.counts)
    result = emg7_result(results, settings, [0, 1], test_clips=256, threads=1, controls=controls,
                         models=[], figures=[])
    assert result.measured["reconstruction_error"]["7"] is results["reconstruction"]["7"]["mpjpe"]
    assert result.headline == "MPJPE N=5/7: 0.060/0.084 m; generation FID: 0.600/0.840"
    assert "(N = [1, 3] not run at the quick scale: standard and paper scales only;" in result.notes
    assert result.extra["control_calibration"] is controls.planted
    assert result.extra["counts_not_run"] == [1, 3] and result.extra["scale"] == "quick"


def test_the_sets_of_three_summary_line_gives_each_rows_rate() -> None:
    rows = [("SEF", "0.1,0.7,0.2")]
    line = summary_line({"0.1,0.7,0.2": {"both_present": [0.5]}},
                        {"0.1,0.7,0.2": {"both_present": [0.25]}},
                        {"0.1,0.7,0.2": {"both_present": [1.0]}}, rows)
    assert line == ("- Sets of three (outside the rules): all three found for SEF 25%; the same "
                    "motions as lower + wave_both (control): both found for SEF 100%; on the "
                    "held-out pairs both found for SEF 50%")
