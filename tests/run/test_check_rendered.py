"""scripts/check_rendered.py: a real headless Chromium, offline, finds a figure that does not
load, a broken link or anchor, a page that asks the network for a script, and equations left
as raw TeX; a page rendered by the snapshot's exporter passes; without Chromium the script says
so and exits 0."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from repro.infra import paths

SCRIPT = paths.REPO_ROOT / "scripts" / "check_rendered.py"
PNG = bytes.fromhex("89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c489"
                    "0000000d49444154789c6360000002000154a24f5d0000000049454e44ae426082")


def _run(*arguments: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *arguments], capture_output=True,
                          text=True, timeout=120, env={**os.environ, **(env or {})})


def _site(root: Path, *, broken: bool) -> Path:
    (root / "figures").mkdir(parents=True)
    (root / "figures" / "ok.png").write_bytes(PNG)
    extra = "<img src='figures/gone.png'><a href='missing.html'>x</a>" if broken else ""
    (root / "page.html").write_text(f"<!doctype html><title>t</title><h1 id='top'>t</h1>"
                                    f"<img src='figures/ok.png'><a href='#top'>top</a>{extra}")
    anchors = "[gone](#nowhere)" if broken else ""
    (root / "REPORT.md").write_text(
        "# r\n\n![f](figures/ok.png)\n\n[page](page.html) [A3](#gmd-a3) [models](#models) "
        f"{anchors}\n\n<a id=\"gmd-a3\"></a>\n\n## GMD-A3 — inconclusive\n\n## Models\n")
    return root


def test_without_chromium_it_says_so_and_does_not_fail(tmp_path: Path) -> None:
    result = _run(str(_site(tmp_path, broken=True)), env={"CHROMIUM": "/no/such/chromium"})
    assert result.returncode == 0
    assert "SKIPPED: Chromium is not installed" in result.stdout
    assert _run(str(tmp_path), "--require-chromium",
                env={"CHROMIUM": "/no/such/chromium"}).returncode == 2


NO_CHROMIUM = pytest.mark.skipif(
    not any(shutil.which(b) for b in ("chromium", "chromium-browser")),
    reason="Debian's chromium is not installed (apt-get install chromium)")


@NO_CHROMIUM
def test_chromium_finds_broken_figures_and_links(tmp_path: Path) -> None:
    good = _run(str(_site(tmp_path / "good", broken=False)))
    assert good.returncode == 0, good.stdout + good.stderr
    assert "2 page(s) checked" in good.stdout and "no problem" in good.stdout
    bad = _run(str(_site(tmp_path / "bad", broken=True)))
    assert bad.returncode == 1
    assert "image 'figures/gone.png' did not load" in bad.stdout
    assert "link 'missing.html' points at a missing file" in bad.stdout
    assert "in-page link '#nowhere' names no element" in bad.stdout
    assert "#gmd-a3" not in bad.stdout and "#models" not in bad.stdout


@NO_CHROMIUM
def test_offline_it_fails_raw_tex_untypeset_math_and_network_scripts(tmp_path: Path) -> None:
    (tmp_path / "raw.html").write_text(
        "<!doctype html><title>t</title><p>The energy $E_\\theta(z_t, c)$ and \\(x^2\\).</p>"
        "<p>$$\\sum_i w_i$$</p><pre>$in_code$</pre><p>costs $5 and $10</p>"
        "<p><math><mi>\\varnothingx</mi></math></p>"
        "<script src='https://cdn.example.org/mathjax.js'></script>", encoding="utf-8")
    result = _run(str(tmp_path / "raw.html"))
    assert result.returncode == 1, result.stdout + result.stderr
    assert "raw TeX in the text, not typeset: '$E_\\\\theta(z_t, c)$'" in result.stdout
    assert "'\\\\(x^2\\\\)'" in result.stdout and "'$$\\\\sum_i w_i$$'" in result.stdout
    assert "in_code" not in result.stdout and "$5" not in result.stdout
    assert "math element still holds a TeX command: '\\\\varnothingx'" in result.stdout
    assert "asks the network for https://cdn.example.org/mathjax.js" in result.stdout


@NO_CHROMIUM
def test_a_notebook_rendered_for_the_snapshot_passes_offline(tmp_path: Path) -> None:
    """The snapshot's exporter (claims.provenance) writes equations Chromium typesets with
    no network: the page passes, its formulas counted."""
    import nbformat

    from repro.claims.provenance import render_notebooks

    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(
        "# Energy\n\nThe energy $E_\\theta(z_t, c)$ and its step\n\n"
        "$$z_{t-1} = z_t - \\eta_t \\nabla F_t(z_t) + \\sigma_t\\xi$$\n\nIt costs $5.")])
    (tmp_path / "executed").mkdir()
    nbformat.write(notebook, tmp_path / "executed" / "04_energy_contour_maps.ipynb")
    render_notebooks(tmp_path / "executed", tmp_path / "notebooks")
    result = _run(str(tmp_path / "notebooks"))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "2 formula(s)" in result.stdout and "no problem" in result.stdout


def test_math_not_laid_out_as_math_is_a_problem() -> None:
    """A browser without MathML shows a <math> element as inline text: that is no equation."""
    spec = importlib.util.spec_from_file_location("check_rendered", SCRIPT)
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    found = {"text": "", "math_errors": [], "math": [
        {"text": "Eθ", "display": "inline", "width": 20.0, "height": 12.0},
        {"text": "x", "display": "math", "width": 0.0, "height": 0.0},
        {"text": "y", "display": "block math", "width": 9.0, "height": 11.0}]}
    problems = script.math_problems(found, Path("p.html"))
    assert problems == ["p.html: math element not laid out as math (display 'inline'): 'Eθ'",
                        "p.html: math element not laid out as math (display 'math'): 'x'"]
