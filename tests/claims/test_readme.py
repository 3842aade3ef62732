"""README's verdict table is the committed snapshot's (results/claims.json), and README stays
a five-minute read (at most 200 lines; measurements and pilots go to docs/)."""

from __future__ import annotations

from pathlib import Path

from repro.claims.report import readme_claims_table, update_readme_table
from repro.infra import paths
from repro.infra.storage import read_json


def test_readme_table_matches_the_results_snapshot() -> None:
    rows = read_json(paths.results_dir() / "claims.json")["claims"]
    readme = (paths.REPO_ROOT / "README.md").read_text(encoding="utf-8")
    assert readme_claims_table(rows) in readme


README_MAX_LINES = 200


def test_readme_is_a_five_minute_read() -> None:
    lines = (paths.REPO_ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, (
        f"README.md has {len(lines)} lines (at most {README_MAX_LINES}): move measurements "
        "and details to docs/")


def test_update_replaces_only_the_marked_table(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- claims-table:start x -->\n| old |\n<!-- claims-table:end -->\n"
                      "outro\n", encoding="utf-8")
    rows = [{"id": "GMD-A1", "verdict": "reproduced", "notebook": "01_x0_vs_eps"}]
    update_readme_table(readme, rows)
    text = readme.read_text(encoding="utf-8")
    assert "| old |" not in text and "| GMD-A1 | reproduced | `01_x0_vs_eps` |" in text
    assert text.startswith("intro\n<!-- claims-table:start x -->\n") and text.endswith("outro\n")


def test_rows_show_parts_for_anything_but_reproduced_and_what_changed() -> None:
    rows = [{"id": "EMG-8", "verdict": "inconclusive", "notebook": "08_composed_augmentation",
             "registry_version": "4", "previous_verdict": "not reproduced (v1)",
             "parts_short": "r_precision_improves: below resolution; fid_improves: absent"},
            {"id": "GMD-A2", "verdict": "reproduced", "notebook": "01_x0_vs_eps",
             "registry_version": "4", "previous_verdict": "reproduced (v1)", "parts_short": ""}]
    table = readme_claims_table(rows)
    assert ("| EMG-8 | inconclusive — r_precision_improves: below resolution; fid_improves: "
            "absent (was: not reproduced (v1)) | `08_composed_augmentation` |") in table
    assert "| GMD-A2 | reproduced | `01_x0_vs_eps` |" in table
