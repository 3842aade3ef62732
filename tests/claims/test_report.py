"""The report shows each claim's verdict with its parts counted (linked to the claim's section,
where they are in words), and the previous snapshot's verdict (the committed
results/claims.json) beside it; claims.json keeps both. The HTML page is REPORT.md rendered,
every section in both."""

from __future__ import annotations

import html
import re
from pathlib import Path

import pytest
from conftest import make_context, run_settings

from repro.claims import trust
from repro.claims.ledger import record_claim
from repro.claims.registry import REGISTRY_VERSION
from repro.claims.report import RecordedRun, write_report
from repro.infra.storage import read_json, write_json

A3_RUN = run_settings("GMD-A3")


#: GMD-A3 measurements with the ε arm ahead on every seed
A3_MEASURED = {"goal_error_x0": [0.5, 0.6, 0.55], "goal_error_eps": [0.1, 0.13, 0.11],
               "best_gain_survival_eps": [0.9, 0.95, 0.92],
               "guided_change_survival_eps": [0.9, 0.95, 0.92],
               "best_gain_survival_x0": [0.95, 0.99, 0.97],
               "guided_change_survival_x0": [0.95, 0.99, 0.97]}


def test_report_shows_the_previous_snapshot_beside_and_parts_in_words(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    snapshot = tmp_path / "results" / "claims.json"
    write_json(snapshot, {"sidecars": {
        "GMD-A3": {"mode": "full", "verdict": "not reproduced", "registry_version": 1},
        "GMD-A2": {"mode": "full", "verdict": "reproduced", "registry_version": 1}}})
    monkeypatch.setattr(trust.paths, "results_dir", lambda: snapshot.parent)
    ctx = make_context(tmp_path, scale="standard")
    record_claim(ctx, "GMD-A3", A3_MEASURED,
                 settings=A3_RUN, seeds=[0, 1, 2])
    record_claim(ctx, "GMD-A2", {"cosine_x0_share_argmax_fraction": 0.0,
                                 "cosine_eps_share_argmax_fraction": 1.0}, seeds=[0])
    text = write_report(tmp_path, scale="standard").read_text(encoding="utf-8")
    assert f"| verdict (registry v{REGISTRY_VERSION}) | parts | previous snapshot |" in text
    # v4: x0 keeps more of the best gain in every seed: a contradiction, not "power"; the
    # parts' cell counts outcomes and links to the claim's section, where each part is named
    assert ("| [GMD-A3](#gmd-a3) | an x0 model can undo guidance late in sampling while an ε "
            "model keeps it |") in text
    assert ("| **partially reproduced** | [1 supported, 1 contradicted](#gmd-a3) | "
            "not reproduced (v1) |") in text
    assert "| **reproduced** | [2 supported](#gmd-a2) | reproduced (v1) |" in text
    assert "| GMD-A1 | " in text and "| **not yet tested** | — |  |" in text  # no section
    assert '<a id="gmd-a3"></a>\n\n## GMD-A3 — partially reproduced (standard scale)' in text
    assert "eps_keeps_more_of_best_gain: contradicted" in text.split("## GMD-A3")[1]
    assert "- Previous snapshot: not reproduced (v1)" in text
    assert "## Verdict changes since the previous snapshot" in text
    assert (f"**GMD-A3**: v1 *not reproduced* → v{REGISTRY_VERSION} *partially reproduced*"
            in text)
    assert "- Controls: positive: missing; null: missing" in text
    rows = {r["id"]: r for r in read_json(tmp_path / "report" / "claims.json")["claims"]}
    assert rows["GMD-A3"]["previous_verdict"] == "not reproduced (v1)"
    assert rows["GMD-A3"]["registry_version"] == str(REGISTRY_VERSION)


def section_headings(markdown: str) -> list[str]:
    """The ``## `` headings of a Markdown text, in order."""
    return [line[3:].strip() for line in markdown.splitlines() if line.startswith("## ")]


def page_headings(page: str) -> list[str]:
    """The ``<h2>`` headings of an HTML page as text, in order."""
    return [html.unescape(re.sub(r"<[^>]+>", "", h)).strip()
            for h in re.findall(r"<h2[^>]*>(.*?)</h2>", page, re.S)]


def test_the_page_is_the_markdown_rendered_with_every_section(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """index.html is REPORT.md rendered: every section, the caveat, the date and the
    provenance in both; every in-page link names an anchor of the page."""
    monkeypatch.setattr(trust.paths, "results_dir", lambda: tmp_path / "no-results")
    ctx = make_context(tmp_path, scale="standard", run_id="run-1")
    record_claim(ctx, "GMD-A3", A3_MEASURED,
                 settings=A3_RUN, seeds=[0, 1, 2],
                 models=[{"name": "m", "family": "gmd_motion", "gate": {}, "passed": False}])
    text = write_report(tmp_path, scale="standard", provenance="By hand.",
                        runs=[RecordedRun("01_x0_vs_eps", 12.0)]).read_text(encoding="utf-8")
    page = (tmp_path / "report" / "index.html").read_text(encoding="utf-8")
    headings = section_headings(text)
    assert {"How far each verdict can be trusted", "Verdicts", "Paper errata", "Models",
            "Notebook run times", "Verdict changes since the previous snapshot"} <= set(headings)
    assert page_headings(page) == headings
    assert page.count("<h1") == 1 and "<title>Reproduction report (standard scale)</title>" in page
    for words in ("Stand-in data and tiny models", "Generated ", "By hand. Run run-1.",
                  "figures/parts_forest.png", "figures/claims_by_outcome.png"):
        assert words in text and words in page, words
    ids = set(re.findall(r'\bid="([^"]+)"', page))
    links = set(re.findall(r'href="#([^"]+)"', page))
    assert {"gmd-a3", "models"} <= links and links <= ids


def test_models_json_places_the_skating_ratio_among_published_models_and_real_clips(
        tmp_path, monkeypatch) -> None:
    import numpy as np

    from repro.claims import report

    monkeypatch.setattr(report.paths, "humanml3d_sample_dir", lambda: tmp_path / "absent")
    context = report.skating_ratio_context()
    assert context["published"]["GMD"] == 0.111 and context["real_clips"] is None
    (tmp_path / "new_joints").mkdir()
    still = np.zeros((30, 22, 3))                  # feet on the floor, never moving
    sliding = still.copy()
    sliding[:, :, 0] = np.arange(30)[:, None] * 0.1   # 2 m/s along x, feet down
    np.save(tmp_path / "new_joints" / "a.npy", still)
    np.save(tmp_path / "new_joints" / "b.npy", sliding[:20])
    monkeypatch.setattr(report.paths, "humanml3d_sample_dir", lambda: tmp_path)
    real = report.skating_ratio_context()["real_clips"]
    assert real["clips"] == 2 and real["value"] == pytest.approx(19 / (29 + 19))
