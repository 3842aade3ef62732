"""The report opens with the forest plot of every part in units of its δ, and each claim's
part rows carry what the run could see over δ and, for an undecided part, the seeds that
would see δ at the run's spread."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import make_context, run_settings

from repro.claims import trust
from repro.claims.figures import FOREST_NAME, forest_rows
from repro.claims.ledger import load_sidecars, record_claim
from repro.claims.power import ALPHA, seeds_to_see
from repro.claims.registry import CLAIMS, get_claim
from repro.claims.report import parts_rows, write_report


@pytest.fixture
def build(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(trust.paths, "results_dir", lambda: tmp_path / "no-results")
    ctx = make_context(tmp_path, scale="standard")
    rng = np.random.default_rng(4)
    a3 = {"goal_error_x0": [0.5, 0.9, 0.6], "goal_error_eps": [0.6, 0.5, 0.7],   # undecided
          "best_gain_survival_eps": [0.9, 0.3, 0.7], "best_gain_survival_x0": [0.5, 0.8, 0.4],
          "guided_change_survival_eps": [0.9, 0.3, 0.7],
          "guided_change_survival_x0": [0.5, 0.8, 0.4]}
    record_claim(ctx, "GMD-A3", a3, settings=run_settings("GMD-A3"), seeds=[0, 1, 2])
    record_claim(ctx, "GMD-F1", get_claim("GMD-F1").example_at(rng, 3.0, 3),
                 settings=run_settings("GMD-F1"), seeds=[0, 1, 2])
    record_claim(ctx, "GMD-A1", {"max_abs_mu_difference": 1e-15,
                                 "printed_c_max_relative_error": 0.3}, seeds=[0])
    return tmp_path


def test_the_report_opens_with_the_forest_plot(build: Path) -> None:
    text = write_report(build, scale="standard").read_text(encoding="utf-8")
    images = [line for line in text.splitlines() if line.startswith("![")]
    assert images[0].endswith(f"(figures/{FOREST_NAME})")
    assert text.index(FOREST_NAME) < text.index("| claim | verdict | parts |")
    assert (build / "report" / "figures" / FOREST_NAME).stat().st_size > 10_000
    page = (build / "report" / "index.html").read_text(encoding="utf-8")
    assert page.index(FOREST_NAME) < page.index("<th>controls</th>")


def test_forest_rows_put_every_part_in_units_of_its_delta(build: Path) -> None:
    sidecars = load_sidecars(build / "claims")
    rows = forest_rows(sidecars)
    assert [r.claim_id for r in rows if r.note == "not recorded"] == [
        c for c in CLAIMS if c not in sidecars]
    a1 = [r for r in rows if r.claim_id == "GMD-A1"]
    assert a1 and all(r.mean is None and r.note.startswith("exact check") for r in a1)
    f1 = [r for r in rows if r.claim_id == "GMD-F1"]
    assert len(f1) == 5                                    # the coherence part: two comparisons
    part = sidecars["GMD-F1"]["parts"][0]
    row = part["numbers"]["difference"]
    assert f1[0].mean == pytest.approx(row["mean"] / row["smallest_effect"])
    assert f1[0].low <= f1[0].mean <= f1[0].high
    assert all(r.mean > 1 for r in f1)                      # +3δ planted: right of the band


def test_part_rows_say_what_the_run_could_see_and_the_seeds_that_would_see_delta(
        build: Path) -> None:
    sidecars = load_sidecars(build / "claims")
    for row in parts_rows(sidecars["GMD-F1"]) + parts_rows(sidecars["GMD-A3"]):
        assert float(row[5]) > 0                           # MDE / δ of every part
    undecided = [p for p in sidecars["GMD-A3"]["parts"] if p["outcome"] == "inconclusive"]
    assert undecided
    numbers = undecided[0]["numbers"]["difference"]
    expected = seeds_to_see(numbers["smallest_effect"], numbers["spread"], alpha=ALPHA / 2)
    assert numbers["seeds_to_see_delta"] == expected
    shown = {r[0]: r[6] for r in parts_rows(sidecars["GMD-A3"])}
    assert shown[undecided[0]["name"]] == (str(expected) if expected else "more than 100,000")
    assert (f"{expected} seeds would see δ at this spread" if expected else
            "no seed count up to 100,000") in undecided[0]["reason"]
    assert {r[6] for r in parts_rows(sidecars["GMD-F1"])} == {"—"}   # decided: no seeds
    assert {r[3] for r in parts_rows(sidecars["GMD-F1"])} == {"log ratio"}
    text = write_report(build, scale="standard").read_text(encoding="utf-8")
    assert "| this run could see (80 % power) / δ | seeds that would see δ at this spread |" \
        in text


def test_one_seed_says_plainly_that_it_can_see_nothing(tmp_path: Path) -> None:
    """GMD-C4 at one seed: the MDE is infinite and no spread says how many seeds would do."""
    c4 = get_claim("GMD-C4").example_at(np.random.default_rng(0), 0.0, 1)
    record_claim(make_context(tmp_path, scale="standard"), "GMD-C4", c4,
                 settings=run_settings("GMD-C4"), seeds=[0])
    sidecar = load_sidecars(tmp_path / "claims")["GMD-C4"]
    rows = parts_rows(sidecar)
    assert rows and all(r[5] == "∞ (one seed)" for r in rows)
    assert all(r[6].startswith("unknown: no spread measured") for r in rows)
    assert all(p["outcome"] == "inconclusive" for p in sidecar["parts"])
