"""Markdown becomes a page that reads offline: its math MathML written at build time, a price or
a ``$VARIABLE`` left as text, code left alone, GitHub's heading anchors; the notebooks' pages
load nothing from a CDN, and every formula the notebooks hold converts."""

from __future__ import annotations

import re
import warnings

import nbformat
import pytest

from repro.claims.pages import markdown_html, notebook_exporter, report_page, slug
from repro.infra import paths


def test_math_becomes_mathml_and_the_rest_stays_text() -> None:
    page = markdown_html("Energy $E_\\theta(z_t, c)$ and\n\n$$\\sum_i w_i$$\n\n"
                         "It costs $5 and $10; `$kept$` is code; see $REPRO_CACHE_DIR/a and "
                         "$HOME.\n")
    assert page.count("<math") == 2 and 'display="block"' in page
    assert "<msub><mi>E</mi><mi>θ</mi></msub>" in page.replace("&#x003B8;", "θ")
    assert "It costs $5 and $10;" in page and "<code>$kept$</code>" in page
    assert "$REPRO_CACHE_DIR/a and $HOME." in page


def test_a_formula_the_converter_cannot_read_stays_tex_with_a_warning() -> None:
    with pytest.warns(UserWarning, match="formula left as TeX"):
        page = markdown_html("broken $\\frac{a}{$ here\n")
    assert "$\\frac{a}{$" in page and "<math" not in page


def test_headings_carry_githubs_anchors_and_tables_render() -> None:
    assert slug("GMD-A3 — inconclusive (standard scale)") == "gmd-a3--inconclusive-standard-scale"
    assert slug("Verdict changes since the <em>previous</em> snapshot") == (
        "verdict-changes-since-the-previous-snapshot")
    page = markdown_html("## Models\n\n## Models\n\n| a | b |\n|---|---|\n| x \\| y | "
                         "[GMD-A3](#gmd-a3) |\n")
    assert '<h2 id="models">Models</h2>' in page and '<h2 id="models-1">Models</h2>' in page
    assert "<td>x | y</td>" in page and '<td><a href="#gmd-a3">GMD-A3</a></td>' in page
    whole = report_page("# Report\n\nA part's $\\delta$.\n", "Report (standard scale)")
    assert whole.startswith("<!doctype html>") and "<title>Report (standard scale)</title>" in whole
    assert "<script" not in whole and whole.count("<math") == 1 and "$" not in whole


def _notebook_formulas() -> list[str]:
    formulas = []
    for notebook in sorted((paths.REPO_ROOT / "notebooks").glob("*.ipynb")):
        for cell in nbformat.read(notebook, as_version=4).cells:
            if cell.cell_type == "markdown" and "$" in cell.source:
                formulas.append(cell.source)
    return formulas


def test_every_formula_of_the_notebooks_converts() -> None:
    """Each notebook's Markdown, as the snapshot renders it: every formula MathML, none left
    as TeX, no TeX command the converter did not know inside a formula."""
    cells = _notebook_formulas()
    assert len(cells) >= 5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pages = [markdown_html(cell) for cell in cells]
    for page in pages:
        for formula in re.findall(r"<math.*?</math>", page, re.S):
            assert not re.search(r">\\[A-Za-z]+", formula), formula
        assert not re.search(r"\$[^\s$][^$]*\$", re.sub(r"<code>.*?</code>", "", page))


def test_notebook_pages_load_nothing_from_a_cdn_and_typeset_latex_outputs() -> None:
    cell = nbformat.v4.new_code_cell("x**2")
    cell.outputs = [nbformat.v4.new_output("display_data", data={
        "text/latex": "$\\displaystyle x^{2}$", "text/plain": "x**2"})]
    notebook = nbformat.v4.new_notebook(cells=[
        nbformat.v4.new_markdown_cell("# N\n\nThe step $z_{t-1} = z_t - \\eta\\nabla F$."), cell])
    body, _ = notebook_exporter().from_notebook_node(notebook,
                                                     resources={"metadata": {"name": "n"}})
    assert not re.search(r"<script[^>]+src=\"https?:", body)
    assert "mathjax" not in body.lower() and "require.min.js" not in body
    assert body.count("<math") == 2 and "$" not in re.sub(r"<style.*?</style>", "", body,
                                                           flags=re.S)
