"""Which runs a report's claims come from, and the executed notebooks rendered for reading.

- :func:`check_runs`: a report is of one run. Sidecars of several run IDs (e.g. seed 7's
  GMD-A1 beside seed 0's GMD-A3 after a run that failed half-way), a sidecar of the other
  mode, or no sidecar at all are errors; ``allow_mixed`` lets several runs through and the
  provenance then names every run and its claims.
- :func:`render_notebooks`: each executed notebook as a self-contained HTML page (nbconvert;
  the figures are the notebook's PNG outputs, embedded; the equations MathML, so the page
  reads offline) for the ``results/`` snapshot, its text naming no path of the machine that
  ran it (:func:`portable_strings`).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from repro.infra.paths import portable
from repro.infra.storage import write_text

NO_RUN_ID = "(no run ID: recorded outside the runner)"


class ReportError(ValueError):
    """The sidecars cannot make one honest report; the message says why and what to do."""


def runs_of(sidecars: Mapping[str, Mapping[str, Any]]) -> dict[str, list[str]]:
    """Run ID → the claim IDs recorded by that run, in the sidecars' order."""
    runs: dict[str, list[str]] = {}
    for claim_id, sidecar in sidecars.items():
        runs.setdefault(sidecar.get("run_id") or NO_RUN_ID, []).append(claim_id)
    return runs


def scale_of(sidecar: Mapping[str, Any]) -> str | None:
    """The scale of the run that wrote ``sidecar`` (or of a report's ``claims.json``):
    "quick", "standard" or "paper"; "full" for one written before the scales; None if
    neither is recorded."""
    return sidecar.get("scale") or sidecar.get("mode")


def is_result(sidecar: Mapping[str, Any]) -> bool:
    """Whether ``sidecar`` comes from a run whose verdicts are results (any scale but quick)."""
    return scale_of(sidecar) not in (None, "quick")


def _runs_text(runs: Mapping[str, list[str]]) -> str:
    return "; ".join(f"run {run} ({', '.join(claims)})" for run, claims in runs.items())


def check_runs(sidecars: Mapping[str, Mapping[str, Any]], *, scale: str, folder: Path,
               allow_mixed: bool = False) -> str:
    """Raise :class:`ReportError` unless the sidecars make one report; return the provenance
    line naming the run(s)."""
    if not sidecars:
        raise ReportError(f"no claim is recorded in {folder}: there is nothing to report (run "
                          "the notebooks first: python -m repro reproduce)")
    wrong = sorted(c for c, s in sidecars.items() if s.get("scale") != scale)
    if wrong:
        raise ReportError(f"{folder} is a {scale}-scale run's folder but holds sidecars of "
                          f"another scale (or of a run before the scales): {', '.join(wrong)}; "
                          "remove them and rerun those notebooks")
    runs = runs_of(sidecars)
    if len(runs) > 1 and not allow_mixed:
        raise ReportError(f"the claims in {folder} come from {len(runs)} runs: "
                          f"{_runs_text(runs)}. Rerun the notebooks together "
                          "(python -m repro reproduce), or pass --allow-mixed to report them "
                          "side by side with every run named")
    if len(runs) > 1:
        return f"Mixed runs (--allow-mixed): {_runs_text(runs)}."
    return f"Run {next(iter(runs))}."


def portable_strings(value: Any) -> Any:
    """``value`` (JSON-like: a notebook, a sidecar) with every string written by
    ``paths.portable`` — no absolute path of this machine —, images (``image/*`` outputs)
    left as they are."""
    if isinstance(value, str):
        return portable(value)
    if isinstance(value, list):
        return [portable_strings(item) for item in value]
    if isinstance(value, dict):
        return type(value)({key: item if str(key).startswith("image/")
                            else portable_strings(item) for key, item in value.items()})
    return value


SHARED_STYLE = "notebook.css"
_STYLE_BLOCK = re.compile(r"<style[^>]*>(.*?)</style>", re.S)


def render_notebooks(source: Path, target: Path) -> list[Path]:
    """Every ``source/*.ipynb`` as ``target/<name>.html`` (nbconvert's HTML exporter, lab
    template, figures embedded as PNG data URIs, equations as MathML and no script from the
    network: ``claims.pages.notebook_exporter``); returns the pages written.

    The template's style sheet (about 260 kB, the same for every page) is written once to
    ``target/notebook.css`` and linked, which keeps the snapshot small. Paths of this
    machine (the injected ``build_dir``, printed folders) are written relative to the clone
    or as their variable (:func:`portable_strings`)."""
    import nbformat

    from repro.claims.pages import notebook_exporter

    exporter = notebook_exporter()
    pages = []
    target.mkdir(parents=True, exist_ok=True)
    style = ""
    for notebook_path in sorted(Path(source).glob("*.ipynb")):
        notebook = portable_strings(nbformat.read(notebook_path, as_version=4))
        body, _ = exporter.from_notebook_node(
            notebook, resources={"metadata": {"name": notebook_path.stem}})
        blocks = _STYLE_BLOCK.findall(body)
        style = style or "\n".join(blocks)
        if "\n".join(blocks) == style:  # the template's sheet: link it instead
            body = _STYLE_BLOCK.sub("", body)
            body = body.replace("</head>", f'<link rel="stylesheet" href="{SHARED_STYLE}">\n'
                                "</head>", 1)
        pages.append(write_text(target / f"{notebook_path.stem}.html", body))
    if style:
        write_text(target / SHARED_STYLE, style)
    return pages


def notebooks_section(pages: list[Path], relative_to: Path) -> str:
    """The report's "Executed notebooks" section: a link to each rendered page."""
    lines = ["", "## Executed notebooks", "",
             "Each notebook as the last full run executed it (code, outputs and figures); "
             "open a page in any browser."]
    lines += [f"- [{page.stem}]({os.path.relpath(page, relative_to)})" for page in pages]
    return "\n".join(lines) + "\n"
