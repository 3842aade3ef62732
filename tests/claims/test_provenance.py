"""A report is of one run (mixing needs --allow-mixed and names every run); the snapshot holds
every executed notebook rendered to HTML with its figures, linked from REPORT.md."""

from __future__ import annotations

import base64
import re
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


def test_rendered_notebooks_name_no_path_of_the_machine_that_ran_them(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The injected ``build_dir`` and printed folders read relative to the clone (or as the
    variable that moved them); the executed notebook itself is left as it ran."""
    pytest.importorskip("nbconvert")
    from repro.infra import paths

    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "models"))
    staging = paths.REPO_ROOT / "build" / "runs" / "RUN" / "00_stand_in_data"
    parameters = nbformat.v4.new_code_cell(f'build_dir = "{staging}"')
    printed = nbformat.v4.new_code_cell("print(dataset)")
    printed.outputs = [nbformat.v4.new_output(
        "stream", name="stdout", text=f"dataset: {tmp_path / 'models' / 'datasets' / 'ab'}\n"
                                      f"{paths.REPO_ROOT / 'data_stubs'}: no problems\n")]
    notebook = nbformat.v4.new_notebook(cells=[parameters, printed])
    (tmp_path / "executed").mkdir()
    nbformat.write(notebook, tmp_path / "executed" / "00_stand_in_data.ipynb")
    [page] = render_notebooks(tmp_path / "executed", tmp_path / "snapshot")
    text = page.read_text(encoding="utf-8")
    assert str(paths.REPO_ROOT) not in text and str(tmp_path) not in text
    assert "build/runs/RUN/00_stand_in_data" in text
    assert "dataset: $REPRO_CACHE_DIR/datasets/ab" in text and "data_stubs: no problems" in text
    assert str(staging) in (tmp_path / "executed" / "00_stand_in_data.ipynb").read_text()


def test_rendered_notebooks_read_offline(tmp_path: Path) -> None:
    """Equations are MathML in the page and no script comes from a CDN (no MathJax)."""
    pytest.importorskip("nbconvert")
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(
        "The energy $E_\\theta(z_t, c)$, its gradient\n\n$$\\nabla E_t(z) = "
        "\\epsilon_\\theta(z, t, c)/\\sqrt{1-\\bar\\alpha_t}$$")])
    (tmp_path / "executed").mkdir()
    nbformat.write(notebook, tmp_path / "executed" / "04_energy_contour_maps.ipynb")
    [page] = render_notebooks(tmp_path / "executed", tmp_path / "snapshot")
    text = page.read_text(encoding="utf-8")
    assert text.count("<math") == 2 and "E_\\theta" not in text
    assert not re.search(r"<script[^>]*\bsrc=", text) and "mathjax" not in text.lower()


#: an absolute path of a machine: a folder under one of the usual roots
MACHINE_PATH = re.compile(r"(?<![\w.:/-])/(?:tmp|work|home|root|Users|mnt|srv|scratch|var)/"
                          r"[\w.-]+")


def test_the_committed_rendered_notebooks_name_no_machine_path() -> None:
    """results/notebooks/*.html (and the snapshot's claims and reports) carry relative build
    paths only, whoever's machine ran them."""
    from repro.infra import paths

    results = paths.results_dir()
    found = {page.relative_to(results).as_posix(): sorted(set(MACHINE_PATH.findall(
        page.read_text(encoding="utf-8"))))[:3]
        for page in [*results.glob("notebooks/*.html"), *results.glob("REPORT.*"),
                     results / "claims.json"]}
    assert {name: hits for name, hits in found.items() if hits} == {}


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
