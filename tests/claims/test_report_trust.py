"""REPORT.md opens with the trust screen (verdict, parts, controls, gates, limits per claim),
links the figure of the claims by outcome, and lists the verdict changes since the previous
snapshot with the changelog's reasons; REPORT.html has the same."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import make_context, run_settings

from repro.claims import trust
from repro.claims.changelog import EVERY_CLAIM, claim_changes, ids_in, parse_changelog
from repro.claims.ledger import load_sidecars, record_claim
from repro.claims.registry import CLAIMS, REGISTRY_VERSION
from repro.claims.report import docs_link, write_report
from repro.claims.trust import power_short, previous_snapshot, trust_rows, verdict_changes
from repro.infra.storage import write_json

A3_RUN = run_settings("GMD-A3")

A3 = CLAIMS["GMD-A3"]
#: the reference (ε) arm of GMD-A3, its gates unmeasured: it holds back what the parts read
FAILED_MODEL = {"name": "trajectory-eps", "family": "gmd_trajectory", "gate": {},
                "passed": False, "arm": "eps"}


def _record_a3_with_controls(build: Path, *, models: list[dict]) -> None:
    rng = np.random.default_rng(0)
    record_claim(make_context(build, scale="standard"), "GMD-A3", A3.planted_example(rng),
                 settings=A3_RUN, seeds=list(range(5)), models=models,
                 controls={"positive": A3.planted_example(rng), "null": A3.null_example(rng)})


def test_report_opens_with_the_trust_screen_then_the_table(tmp_path: Path) -> None:
    _record_a3_with_controls(tmp_path, models=[FAILED_MODEL])
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}, seeds=[0])
    text = write_report(tmp_path, scale="standard").read_text(encoding="utf-8")
    trust_at, table_at = text.index("## How far each verdict can be trusted"), text.index(
        "## Verdicts")
    assert trust_at < table_at < text.index("## Paper errata") < text.index("## Models")
    screen = text[trust_at:table_at]
    a3 = next(line for line in screen.splitlines() if line.startswith("| [GMD-A3](#gmd-a3) |"))
    # a model that fails its gate makes the verdict inconclusive, and the row says why
    assert "**inconclusive**" in a3 and "positive seen, null silent" in a3
    assert "**1 of 1 fail** (see [Models](#models))" in a3
    assert "quality gates" in a3 and "stand-in data, tiny models" in a3
    assert ("| [GMD-A1](#gmd-a1) | **discrepancy in the paper** | 2 supported | "
            "— (exact check) | "
            "— (no model) | none (an exact computation, no trained model) |") in screen
    assert "| GMD-A2 | **not yet tested** |" in screen
    assert ("21 claims: 1 inconclusive, 1 discrepancy in the paper, 19 not yet tested "
            f"(registry v{REGISTRY_VERSION})") in screen
    assert "![The 21 claims by outcome](figures/claims_by_outcome.png)" in screen
    figure = tmp_path / "report" / "figures" / "claims_by_outcome.png"
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and figure.stat().st_size < 150_000
    page = (tmp_path / "report" / "index.html").read_text(encoding="utf-8")
    assert "How far each verdict can be trusted" in page and "Paper errata" in page
    assert ('<td><strong>1 of 1 fail</strong> (see <a href="#models">Models</a>)</td>'
            in page and '<h2 id="models">Models</h2>' in page)
    assert '<a href="#gmd-a3">GMD-A3</a>' in page and '<a id="gmd-a3"></a>' in page
    assert 'src="figures/claims_by_outcome.png"' in page


def test_passing_models_and_missing_controls_read_as_such(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", A3.planted_example(rng),
                 settings=A3_RUN, seeds=list(range(5)),
                 models=[{**FAILED_MODEL, "passed": True, "arm": None}])
    row = next(r for r in trust_rows(load_sidecars(tmp_path / "claims")) if r.claim_id == "GMD-A3")
    assert row.verdict != "quick run (not a result)"
    assert row.controls == "no positive control, no null control"
    assert row.models == "1/1 pass" and "controls" in row.limits
    assert "quality gates" not in row.limits


def test_power_limits_say_what_the_run_could_see(tmp_path: Path) -> None:
    # 3 seeds spread far wider than δ: the parts the run could not decide say how large an
    # effect it could have seen, in units of δ
    noisy = {"goal_error_x0": [0.5, 0.9, 0.2], "goal_error_eps": [0.6, 0.4, 0.5],
             "best_gain_survival_eps": [0.9, 0.3, 0.7], "best_gain_survival_x0": [0.5, 0.8, 0.4],
             "guided_change_survival_eps": [0.9, 0.3, 0.7],
             "guided_change_survival_x0": [0.5, 0.8, 0.4]}
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", noisy, settings=A3_RUN,
                 seeds=[0, 1, 2])
    sidecar = load_sidecars(tmp_path / "claims")["GMD-A3"]
    undecided = [p for p in sidecar["parts"] if p["outcome"] == "inconclusive"]
    assert undecided, "the null example should leave a part undecided"
    text = power_short(sidecar)
    assert text.startswith(f"power ({len(undecided)} of 2 parts: this run could see ")
    assert text.endswith("× δ)")
    assert power_short({"parts": [{"name": "x", "outcome": "supported"}]}) == ""


def test_a_value_the_run_did_not_measure_and_a_single_seed_read_in_words(
        tmp_path: Path) -> None:
    """GMD-C4 at the standard scale runs k = 10 on one seed only: its row names the part not
    measured by its measurement, and the one-seed part without an "inf× δ"."""
    measured = {"values": [10], "foot_skating_loss_scaling": {"10": [0.57]},
                "foot_skating_emphasis": {"10": [20.7]}}
    record_claim(make_context(tmp_path, scale="standard"), "GMD-C4", measured, seeds=[0],
                 settings=run_settings("GMD-C4"))
    sidecar = load_sidecars(tmp_path / "claims")["GMD-C4"]
    reasons = {p["name"]: p["reason"] for p in sidecar["parts"]}
    assert reasons["emphasis_less_foot_skating_at_2"] == (
        "measurement foot_skating_loss_scaling[2] not recorded")
    limits = trust.limits_text(CLAIMS["GMD-C4"], sidecar)
    assert "inf" not in limits
    assert limits.startswith("not measured by this run (emphasis_less_foot_skating_at_2); "
                             "power (1 of 2 parts: one part on one seed, which decides no "
                             "direction)")


def test_an_exact_check_of_a_trained_model_does_not_say_no_trained_model(
        tmp_path: Path) -> None:
    """EMG-1's rule is exact, but it measures the trained denoiser: beside its passing gates
    the row says so, not "no trained model"; a failing gate is a limit too."""
    exact_of_model = {"registry_version": REGISTRY_VERSION, "parts": [],
                      "models": [{"name": "denoiser", "passed": True}],
                      "quality_gates": {"evaluator": True}}
    claim = CLAIMS["EMG-1"]
    assert trust.gates_text(claim, exact_of_model) == "2/2 pass"
    limits = trust.limits_text(claim, exact_of_model)
    assert "no trained model" not in limits and "exact measurement of trained models" in limits
    failing = {**exact_of_model, "quality_gates": {"evaluator": False}}
    assert "quality gates" in trust.limits_text(claim, failing)
    no_model = {"registry_version": REGISTRY_VERSION, "parts": []}
    assert trust.limits_text(CLAIMS["GMD-A1"], no_model) == (
        "none (an exact computation, no trained model)")
    assert trust.controls_text(claim, exact_of_model) == "— (exact check)"


def test_an_exact_check_with_controls_shows_them_and_is_limited_by_a_failed_one() -> None:
    """EMG-1 records controls (a gradient field, one twice the tolerance away): the row shows
    them as for a claim on effects, and a fired null limits it."""
    claim = CLAIMS["EMG-1"]
    sidecar = {"registry_version": REGISTRY_VERSION, "parts": [],
               "models": [{"name": "denoiser", "passed": True}],
               "controls": {"positive": {"status": "passed"}, "null": {"status": "passed"}}}
    assert trust.controls_text(claim, sidecar) == "positive seen, null silent"
    assert "controls" not in trust.limits_text(claim, sidecar)
    fired = {**sidecar, "controls": {"positive": {"status": "passed"},
                                     "null": {"status": "failed"}}}
    assert trust.controls_text(claim, fired) == "positive seen, null **fired**"
    assert "controls" in trust.limits_text(claim, fired)


def test_verdict_changes_cite_the_changelog(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    snapshot = tmp_path / "results" / "claims.json"
    write_json(snapshot, {"sidecars": {"GMD-A3": {"mode": "full", "verdict": "reproduced",
                                                  "registry_version": 1},
                                       "GMD-A4": {"mode": "quick", "verdict": "reproduced"}}})
    monkeypatch.setattr(trust.paths, "results_dir", lambda: snapshot.parent)
    assert set(previous_snapshot()) == {"GMD-A3"}          # quick sidecars are no snapshot
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3",
                 A3.example_at(np.random.default_rng(0), -3.0, 3), settings=A3_RUN,
                 seeds=[0, 1, 2])
    sidecars = load_sidecars(tmp_path / "claims")
    changes = verdict_changes(sidecars, previous_snapshot(), claim_changes())
    assert [(c.claim_id, c.previous, c.previous_version, c.current) for c in changes] == [
        ("GMD-A3", "reproduced", 1, "not reproduced")]
    assert all(ch.version >= 2 for ch in changes[0].changes) and changes[0].changes
    every = max(ch.version for ch in claim_changes()[EVERY_CLAIM])
    text = write_report(tmp_path, scale="standard").read_text(encoding="utf-8")
    section = text[text.index("## Verdict changes since the previous snapshot"):]
    assert f"- **GMD-A3**: v1 *reproduced* → v{REGISTRY_VERSION} *not reproduced*." in section
    docs = docs_link(tmp_path / "report")
    assert f"[v{every}: For every claim]({docs}/REGISTRY_CHANGELOG.md#" in section
    assert (tmp_path / "report" / docs / "REGISTRY_CHANGELOG.md").is_file()
    assert (tmp_path / "report" / docs / "ERRATA.md").is_file()
    assert f"]({docs}/ERRATA.md)" in text


CHANGELOG = """# Registry changelog

## Version 3 (issues #14, #17)

### For every claim

- Gates make a part inconclusive.

### GMD-A3, GMD-F1 (#17: guidance at T = 1000)

- Guidance at T = 1000, as the paper.
  Continued on a second line.

## Version 2 (issue #13)

### For every claim

- Five outcomes.

### Per claim

- **GMD-A1, A2, C3** (exact checks): unchanged.
- **EMG-2, EMG-3**: a t-test of 2·kept − baseline.
- Not a claim bullet.
"""


def test_changelog_bullets_are_read_per_claim_newest_first() -> None:
    changes = parse_changelog(CHANGELOG)
    assert [c.version for c in changes["GMD-A3"]] == [3]
    assert changes["GMD-A3"][0].text == "Guidance at T = 1000, as the paper. Continued on a " \
        "second line."
    assert changes["GMD-A3"][0].anchor == "gmd-a3-gmd-f1-17-guidance-at-t--1000"
    assert {c for c in changes if c.startswith("GMD")} == {"GMD-A1", "GMD-A2", "GMD-A3",
                                                           "GMD-C3", "GMD-F1"}
    assert [c.anchor for c in changes[EVERY_CLAIM]] == ["for-every-claim", "for-every-claim-1"]
    assert changes["EMG-3"][0].section == "Per claim"
    assert ids_in("GMD-A1, A2, B1") == ["GMD-A1", "GMD-A2", "GMD-B1"]
    assert ids_in("EMG-5, EMG-6 (#16: MTT-style timelines)") == ["EMG-5", "EMG-6"]


def test_every_registry_claim_has_a_reason_in_the_changelog() -> None:
    changes = claim_changes()
    assert [claim_id for claim_id in CLAIMS if not changes.get(claim_id)] == []


def test_the_snapshot_holds_both_reports_the_figure_and_the_budgets(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("nbconvert")
    import json

    import nbformat

    from repro.claims.budgets import README_BUDGETS_END, README_BUDGETS_START
    from repro.claims.report import README_TABLE_END, README_TABLE_START, write_snapshot
    from repro.infra import paths

    repo = tmp_path / "repo"
    repo.mkdir()
    (repo / "README.md").write_text(f"# r\n{README_TABLE_START} -->\n{README_TABLE_END}\n"
                                    f"{README_BUDGETS_START} -->\n{README_BUDGETS_END}\n")
    (repo / "docs").mkdir()
    (repo / "docs" / "ERRATA.md").write_bytes((paths.REPO_ROOT / "docs" / "ERRATA.md").read_bytes())
    monkeypatch.setattr(paths, "REPO_ROOT", repo)
    build = tmp_path / "build"
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(build))
    (build / "bench").mkdir(parents=True)
    (build / "bench" / "bench.json").write_text(json.dumps({"rows": {"reproduce_standard_cold": {
        "seconds": 3000.0, "exit_code": 0, "commit": "c1"}}}))
    _record_a3_with_controls(build, models=[])
    (build / "notebooks").mkdir()
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("# 01")]),
                   build / "notebooks" / "01_x0_vs_eps.ipynb")
    write_report(build, scale="standard")
    (repo / "results").mkdir()
    (repo / "results" / "STABILITY.md").write_text("# seeds 0 and 3\n")
    (repo / "results" / "old.png").write_text("a file of the previous run")
    results = write_snapshot(build)
    assert "[docs/ERRATA.md](../docs/ERRATA.md)" in (results / "REPORT.md").read_text()
    # another command's file is kept (README links it); the previous run's files are not
    assert (results / "STABILITY.md").read_text() == "# seeds 0 and 3\n"
    assert not (results / "old.png").exists()
    page = (results / "REPORT.html").read_text(encoding="utf-8")
    assert "How far each verdict can be trusted" in page
    # REPORT.html is the snapshot's REPORT.md rendered: the same sections, executed notebooks too
    markdown = (results / "REPORT.md").read_text(encoding="utf-8")
    assert [re.sub(r"<[^>]+>", "", h) for h in re.findall(r"<h2[^>]*>(.*?)</h2>", page)] == [
        line[3:] for line in markdown.splitlines() if line.startswith("## ")]
    assert "## Executed notebooks" in markdown
    assert '<a href="notebooks/01_x0_vs_eps.html">01_x0_vs_eps</a>' in page
    assert '<a href="../docs/ERRATA.md">docs/ERRATA.md</a>' in page
    assert (results / "figures" / "claims_by_outcome.png").is_file()
    readme = (repo / "README.md").read_text(encoding="utf-8")
    row = "| cold standard `make reproduce` (the run) | 50.0 min | — | c1 | 75.0 min | within |"
    assert row in readme
    # a later snapshot without a bench keeps each timing's newest measurement
    (build / "bench" / "bench.json").unlink()
    write_snapshot(build)
    assert row in (repo / "README.md").read_text(encoding="utf-8")


def test_a_quick_run_shows_its_machinery_never_its_verdict(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    record_claim(make_context(tmp_path, scale="quick"), "GMD-A3", A3.planted_example(rng),
                 settings=run_settings("GMD-A3", "quick"), seeds=[0], models=[FAILED_MODEL])
    row = next(r for r in trust_rows(load_sidecars(tmp_path / "claims")) if r.claim_id == "GMD-A3")
    assert row.verdict == "quick run (not a result)"
    assert row.models == f"**1 of 1 fail** {trust.SEE_MODELS}" and row.parts != "—"


def test_a_sidecar_of_another_registry_version_says_so() -> None:
    sidecar = {"verdict": "reproduced", "mode": "full", "registry_version": 1}
    row = next(r for r in trust_rows({"GMD-A2": sidecar}) if r.claim_id == "GMD-A2")
    assert row.limits.startswith(f"decided under registry v1, not v{REGISTRY_VERSION}")
    assert row.parts == "—"


def test_parts_not_run_are_named_and_only_gates_a_running_part_reads_limit(
        tmp_path: Path) -> None:
    """A part its scale does not run is "not measured by this run"; a failed model read only
    by such parts is shown but limits nothing; a claim none of whose parts runs has no
    controls or gates to blame."""
    rng = np.random.default_rng(2)
    measured = {k: v for k, v in A3.planted_example(rng).items()
                if not k.startswith("best_gain")}
    cut = {"eps_keeps_more_of_best_gain": "its arm is not trained"}
    only_cut = {**FAILED_MODEL, "reads": ["eps_keeps_more_of_best_gain"]}
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", measured, settings=A3_RUN,
                 seeds=list(range(5)), models=[only_cut], not_run=cut)
    sidecar = load_sidecars(tmp_path / "claims")["GMD-A3"]
    limits = trust.limits_text(A3, sidecar)
    assert limits.startswith("not measured by this run (eps_keeps_more_of_best_gain)")
    assert "quality gates" not in limits
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", measured, settings=A3_RUN,
                 seeds=list(range(5)), models=[{**FAILED_MODEL, "reads": None}], not_run=cut)
    assert "quality gates" in trust.limits_text(A3, load_sidecars(tmp_path / "claims")["GMD-A3"])
    every = {part.name: "cut" for part in A3.parts}
    record_claim(make_context(tmp_path, scale="standard"), "GMD-A3", {}, settings=A3_RUN,
                 seeds=[0, 1, 2], models=[FAILED_MODEL], not_run=every)
    sidecar = load_sidecars(tmp_path / "claims")["GMD-A3"]
    row = next(r for r in trust_rows({"GMD-A3": sidecar}) if r.claim_id == "GMD-A3")
    assert row.controls == "not run at this scale"
    assert row.models.endswith("deciding nothing; no part runs") and "**" not in row.models
    assert "controls" not in row.limits and "quality gates" not in row.limits
