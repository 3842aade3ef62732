"""A report is of one run (mixing needs --allow-mixed and names every run); the snapshot holds
every executed notebook rendered to HTML with its figures, linked from REPORT.md."""

from __future__ import annotations

import base64
from pathlib import Path

import nbformat
import pytest

from repro.claims.provenance import (
    NO_RUN_ID,
    ReportError,
    check_runs,
    notebooks_section,
    render_notebooks,
    runs_of,
)


def _sidecar(run_id: str, scale: str = "standard") -> dict:
    return {"run_id": run_id, "scale": scale}


def test_one_run_is_named_and_several_are_refused() -> None:
    one = {"GMD-A1": _sidecar("r1"), "GMD-A2": _sidecar("r1")}
    assert check_runs(one, scale="standard", folder=Path("c")) == "Run r1."
    mixed = {"GMD-A1": _sidecar("r7"), "GMD-A3": _sidecar("r0"), "GMD-A4": _sidecar("")}
    assert runs_of(mixed) == {"r7": ["GMD-A1"], "r0": ["GMD-A3"], NO_RUN_ID: ["GMD-A4"]}
    with pytest.raises(ReportError, match=r"come from 3 runs: run r7 \(GMD-A1\); run r0"):
        check_runs(mixed, scale="standard", folder=Path("c"))
    line = check_runs(mixed, scale="standard", folder=Path("c"), allow_mixed=True)
    assert line.startswith("Mixed runs (--allow-mixed): run r7 (GMD-A1); run r0 (GMD-A3)")
    with pytest.raises(ReportError, match="no claim is recorded in c"):
        check_runs({}, scale="standard", folder=Path("c"))
    with pytest.raises(ReportError, match="standard-scale run's folder but holds sidecars of "
                                          "another scale"):
        check_runs({"GMD-A1": _sidecar("r1", "quick")}, scale="standard", folder=Path("c"))




def test_executed_notebooks_render_to_html_with_their_figures(tmp_path: Path) -> None:
    pytest.importorskip("nbconvert")
    import matplotlib

    matplotlib.use("Agg")
    import io

    import matplotlib.pyplot as plt

    figure = io.BytesIO()
    plt.plot([0, 1])
    plt.savefig(figure, format="png", dpi=50)
    cell = nbformat.v4.new_code_cell("plot()")
    cell.outputs = [nbformat.v4.new_output(
        "display_data", data={"image/png": base64.b64encode(figure.getvalue()).decode()})]
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("# GMD-A1"), cell])
    (tmp_path / "executed").mkdir()
    nbformat.write(notebook, tmp_path / "executed" / "01_x0_vs_eps.ipynb")
    pages = render_notebooks(tmp_path / "executed", tmp_path / "snapshot" / "notebooks")
    assert pages == [tmp_path / "snapshot" / "notebooks" / "01_x0_vs_eps.html"]
    text = pages[0].read_text()
    assert "GMD-A1" in text and "data:image/png;base64," in text
    assert '<link rel="stylesheet" href="notebook.css">' in text and "<style" not in text
    assert (tmp_path / "snapshot" / "notebooks" / "notebook.css").stat().st_size > 1000
    section = notebooks_section(pages, tmp_path / "snapshot")
    assert "- [01_x0_vs_eps](notebooks/01_x0_vs_eps.html)" in section


def test_the_snapshot_holds_the_rendered_notebooks_linked_from_the_report(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("nbconvert")
    from conftest import make_context

    from repro.claims.ledger import record_claim
    from repro.claims.report import (
        README_TABLE_END,
        README_TABLE_START,
        write_report,
        write_snapshot,
    )
    from repro.infra import paths

    repo = tmp_path / "repo"
    repo.mkdir()
    (repo / "README.md").write_text(f"# r\n\n{README_TABLE_START} -->\n{README_TABLE_END}\n")
    monkeypatch.setattr(paths, "REPO_ROOT", repo)
    build = tmp_path / "build"
    record_claim(make_context(build, scale="standard", run_id="run-1"), "GMD-A1",
                 {"max_abs_mu_difference": 0.0, "printed_c_max_relative_error": 0.5}, seeds=[0])
    (build / "notebooks").mkdir()
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("# 01")]),
                   build / "notebooks" / "01_x0_vs_eps.ipynb")
    write_report(build, scale="standard")
    results = write_snapshot(build)
    assert results == repo / "results"
    assert (results / "notebooks" / "01_x0_vs_eps.html").is_file()
    report = (results / "REPORT.md").read_text()
    assert "Run run-1." in report
    assert "- [01_x0_vs_eps](notebooks/01_x0_vs_eps.html)" in report
