"""The report: REPORT.md built from the claim sidecars, the same rendered as an HTML page, and
the committed ``results/`` snapshot.

REPORT.md opens with one screen on trust (``claims.trust``): the forest plot of every part in
units of its δ (``claims.figures.forest_plot``), per claim its verdict, parts, controls, gates
and limits, and the figure of the claims by outcome;
then the verdict table beside the previous snapshot's verdicts (the committed
``results/claims.json`` when the report is written), the verdict changes since it with the
changelog's reasons (``claims.changelog``), the papers' errata (``docs/ERRATA.md`` via
``claims.errata``), the models, the run times and each claim in full, its rule as the run
rendered it and its part rows (:func:`parts_rows`: effect and interval over δ, what the run
could see over δ, and for an undecided part the seeds that would see δ). The verdict table's
cells stay short (the parts' outcomes counted); each claim links to its section
(``#gmd-a3``).

REPORT.md is the one source: the HTML page (``index.html``; ``REPORT.html`` in ``results/``) is
that Markdown rendered (``claims.pages``, its math typeset as MathML), so every section is in
both.

A quick run's verdicts are never presented as results: its table says "quick run" instead.
Reports are written atomically; a failed run does not call this (the last good one stays).
"""

from __future__ import annotations

import datetime as _dt
import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from repro.claims import changelog, errata, trust
from repro.claims.budgets import (
    README_BUDGETS_START,
    bench_timings,
    kept_timings,
    run_span_seconds,
    update_readme_budgets,
)
from repro.claims.figures import (
    FIGURE_NAME,
    FOREST_NAME,
    claims_by_outcome,
    comparisons_of,
    forest_plot,
)
from repro.claims.ledger import load_sidecars, part_outcomes
from repro.claims.power import MOST_SEEDS
from repro.claims.provenance import (
    ReportError,
    check_runs,
    is_result,
    notebooks_section,
    portable_strings,
    render_notebooks,
    scale_of,
)
from repro.claims.readme import replace_block
from repro.claims.registry import CLAIMS, REGISTRY_VERSION
from repro.claims.verdicts import INCONCLUSIVE
from repro.infra import paths
from repro.infra.paths import portable
from repro.infra.storage import read_json, write_json, write_text


def _format_number(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def headline(sidecar: dict[str, Any], limit: int = 4) -> str:
    """Our key numbers in one line: the notebook's headline, else the first summaries."""
    if sidecar.get("headline"):
        return sidecar["headline"]
    parts = []
    for key, value in list(sidecar.get("summary", {}).items())[:limit]:
        if isinstance(value, dict) and {"mean", "low", "high"} <= set(value):
            parts.append(f"{key} {value['mean']:.3g} [{value['low']:.3g}, {value['high']:.3g}]")
        elif isinstance(value, int | float | bool):
            parts.append(f"{key} {_format_number(value)}")
    return "; ".join(parts)


def _previous_text(previous: dict[str, Any] | None) -> str:
    if previous is None:
        return ""
    scale = previous.get("scale")
    return (f"{previous['verdict']} (v{previous['registry_version']}"
            + (f", {scale} scale)" if scale and scale != "full" else ")"))


def _rows(sidecars: dict[str, dict[str, Any]],
          previous: dict[str, dict[str, Any]]) -> list[dict[str, str]]:
    rows = []
    for claim in CLAIMS.values():
        sidecar = sidecars.get(claim.id)
        row = {"id": claim.id, "statement": claim.statement, "paper": claim.paper_value,
               "notebook": claim.notebook}
        if sidecar is None:
            row.update(verdict="not yet tested", ours="")
        elif not is_result(sidecar):
            row.update(verdict="— (quick run: not a result)", ours=headline(sidecar))
        else:
            row.update(verdict=sidecar["verdict"], ours=headline(sidecar),
                       registry_version=str(sidecar.get("registry_version", 1)),
                       previous_verdict=_previous_text(previous.get(claim.id)),
                       parts=part_outcomes(sidecar),
                       parts_short=part_outcomes(sidecar, reasons=False))
        rows.append(row)
    return rows


def _controls_line(sidecar: dict[str, Any]) -> str:
    controls = sidecar.get("controls")
    if not controls:
        return ""
    words = []
    for kind, control in controls.items():
        if control.get("status") == "missing":
            words.append(f"{kind}: missing")
        else:
            words.append(f"{kind}: {control['status']} ({control.get('verdict')})")
    return "; ".join(words)


PARTS_HEADER = ["part", "outcome", "effect / δ [95 % interval]", "tested on", "δ",
                "this run could see (80 % power) / δ", "seeds that would see δ at this spread"]


def _seeds_text(row: dict[str, Any], outcome: str) -> str:
    """The seeds that would see δ, for an inconclusive part ("—" for a decided one)."""
    if outcome != INCONCLUSIVE or "seeds_to_see_delta" not in row:
        return "—"
    if row.get("spread_unknown"):
        return "unknown: no spread measured (one seed, or no spread)"
    seeds = row["seeds_to_see_delta"]
    return f"more than {MOST_SEEDS:,}" if seeds is None else str(seeds)


def _over_delta(value: float | None, delta: float) -> str:
    if value is None:
        return "—"
    return "∞ (one seed)" if value == float("inf") else f"{value / delta:.2f}"


def parts_rows(sidecar: dict[str, Any]) -> list[list[str]]:
    """Each part's comparisons in units of δ, as the report's part rows: the outcome, the
    effect and its interval over δ, the scale it is tested on, δ, the minimum detectable
    effect over δ (``power.minimum_detectable_effect`` at the run's n and spread) and, for a
    part left inconclusive, the seeds that would see δ at the run's spread
    (``power.seeds_to_see``). A part without numbers (an exact check, a measurement not
    recorded) gets its outcome and reason only."""
    rows = []
    for part in sidecar.get("parts") or []:
        found = comparisons_of(part)
        scale = (part.get("numbers") or {}).get("scale", "difference")
        if not found:
            rows.append([part["name"], part["outcome"], part["reason"], "—", "—", "—", "—"])
            continue
        for label, row in found:
            delta = abs(float(row["smallest_effect"]))
            name = part["name"] if label == "difference" else f"{part['name']}: {label}"
            mde = row.get("minimum_detectable_effect")
            rows.append([
                name, part["outcome"],
                f"{row['mean'] / delta:+.2f} [{row['low'] / delta:+.2f}, "
                f"{row['high'] / delta:+.2f}] (n = {row['n']})", scale,
                f"{row['smallest_effect']:.3g}",
                _over_delta(mde, delta), _seeds_text(row, part["outcome"])])
    return rows


def parts_markdown(sidecar: dict[str, Any]) -> list[str]:
    """:func:`parts_rows` as a Markdown table ([] for a sidecar without parts)."""
    rows = parts_rows(sidecar)
    if not rows:
        return []
    lines = ["", "| " + " | ".join(PARTS_HEADER) + " |", "|" + "---|" * len(PARTS_HEADER)]
    lines += ["| " + " | ".join(c.replace("|", "\\|") for c in r) + " |" for r in rows]
    return lines + [""]


def models_of(sidecars: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    """Every model behind a recorded claim, once per role it was judged in (a model can be one
    claim's treatment arm and another's reference, ``core.gates``), with the claim IDs that
    use it so (``results/models.json``: ``family``, ``role``, ``claims``, ``gate``,
    ``passed``, …)."""
    models: dict[tuple[str, str], dict[str, Any]] = {}
    for claim_id, sidecar in sidecars.items():
        for record in sidecar.get("models", []):
            key = (record["name"], str(record.get("role", "")))
            entry = models.setdefault(key, {**record, "claims": [], "holds_back": []})
            entry["claims"].append(claim_id)
            entry["holds_back"] += [f"{claim_id} {part} ({', '.join(gates)})" for part, gates
                                    in (record.get("holds_back") or {}).items()]
    return [models[key] for key in sorted(models)]


def skating_ratio_context() -> dict[str, Any]:
    """What ``models.json`` places the models' skating ratios among: the published models'
    (:data:`core.gates.PUBLISHED_SKATING_RATIO`) and the real HumanML3D clips beside the clone
    (``../shared/humanml3d_sample/new_joints``, frames weighted alike; None without them)."""
    from repro.core.gates import PUBLISHED_SKATING_RATIO, PUBLISHED_SKATING_RATIO_SOURCE
    from repro.core.metrics import foot_skating_ratio

    clips = sorted((paths.humanml3d_sample_dir() / "new_joints").glob("*.npy"))
    real = None
    if clips:
        joints = [np.load(clip).astype(np.float64) for clip in clips]
        lengths = [len(j) for j in joints]
        padded = np.zeros((len(joints), max(lengths), *joints[0].shape[1:]))
        for i, j in enumerate(joints):
            padded[i, :len(j)] = j
        real = {"clips": len(clips), "value": foot_skating_ratio(padded, lengths=lengths)}
    return {"published": PUBLISHED_SKATING_RATIO, "source": PUBLISHED_SKATING_RATIO_SOURCE,
            "real_clips": real}


def _reported_text(reported: dict[str, Any]) -> str:
    """``metric value (data's)`` for each measurement a model reports beside its gates."""
    return "; ".join(f"{metric} {_number_or_dash(r['value'])} (data {_number_or_dash(r['data'])})"
                     for metric, r in reported.items())


def _number_or_dash(value: float | None) -> str:
    return "—" if value is None else f"{value:.3g}"


def _gate_text(gate: dict[str, Any]) -> str:
    """``metric value (wanted range; the data's value) ✓/✗`` for each gate of one model."""
    cells = []
    for metric, result in gate.items():
        if result.get("applies") is False:
            cells.append(f"{metric} not measurable on this data")
            continue
        low, high = result["at_least"], result["at_most"]
        wanted = (f"{low:.3g}–{high:.3g}" if low is not None and high is not None
                  else f"≤ {high:.3g}" if high is not None else f"≥ {low:.3g}")
        value = "not measured" if result["value"] is None else f"{result['value']:.3g}"
        if result.get("interval") and result["value"] is not None:
            value += f" [{result['interval'][0]:.3g}, {result['interval'][1]:.3g}]"
            value += f", {result['draws']} draws" if result.get("draws", 1) > 1 else ""
        data = "" if result.get("data") is None else f"; data {result['data']:.3g}"
        cells.append(f"{metric} {value} (want {wanted}{data}) "
                     f"{'✓' if result['passed'] else '✗'}")
    return "; ".join(cells)


def models_markdown(models: list[dict[str, Any]]) -> list[str]:
    """The report's "Models" section: every model behind a verdict and its quality gate."""
    lines = ["", "## Models", ""]
    if not models:
        return lines + ["No notebook of this run recorded its models' quality gates yet, so no "
                        "verdict here is backed by a model known to work (gates: "
                        "`repro.core.gates`).", ""]
    lines += ["A failed gate holds back only the parts that read that property of the model "
              "and whose arms differ in it (gates version 5, `repro.claims.gating`): a "
              "component every arm shares is reported beside the part, an arm the claim "
              "predicts worse is gated on its training alone. Each sample gate's value carries "
              "its bootstrap interval.", "",
              "| model | family (role) | claims | steps | training s | gate (value [interval], "
              "wanted range; the data's value) | reported, not gated | passed | holds back |",
              "|---|---|---|---|---|---|---|---|---|"]
    for m in models:
        seconds = "—" if m.get("train_seconds") is None else f"{m['train_seconds']:.0f}"
        family = f"{m['family']} ({m['role']})" if m.get("role") else m["family"]
        cells = [m["name"], family, ", ".join(m["claims"]), str(m.get("steps") or "—"),
                 seconds, _gate_text(m["gate"]), _reported_text(m.get("reported", {})) or "—",
                 "yes" if m["passed"] else "**no**",
                 "; ".join(m.get("holds_back") or []) or "—"]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    context = skating_ratio_context()
    published = ", ".join(f"{name} {value:.3f}" for name, value in context["published"].items())
    real = context["real_clips"]
    lines += ["", f"foot_skating_ratio is GMD's skating ratio (the share of frame steps in which "
              "a foot below 5 cm moves faster than 0.5 m/s, at that step and over 5): published "
              f"on HumanML3D ({context['source']}): {published}; "
              + ("the real clips beside the clone are not here." if real is None else
                 f"the {real['clips']} real HumanML3D clip(s) beside the clone: "
                 f"{real['value']:.3f}.")]
    return lines + [""]


def verdicts_markdown(rows: list[dict[str, str]],
                      sidecars: dict[str, dict[str, Any]]) -> list[str]:
    """The "Verdicts" table: per registry claim its statement, the paper's value, ours, the
    verdict, its parts' outcomes counted and the previous snapshot's verdict, each claim with
    a sidecar linked to its section (where its parts are, with their reasons and numbers)."""
    lines = ["## Verdicts", "",
             f"| claim | statement | paper | ours | verdict (registry v{REGISTRY_VERSION}) "
             "| parts | previous snapshot | notebook |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sidecar = sidecars.get(r["id"])
        parts = (trust.claim_link(r["id"], sidecars,
                                  trust.parts_text(trust.outcome_counts(sidecar)))
                 if sidecar and sidecar.get("parts") else "—")
        cells = [trust.claim_link(r["id"], sidecars), r["statement"], r["paper"], r["ours"],
                 f"**{r['verdict']}**", parts, r.get("previous_verdict", ""),
                 f"`{r['notebook']}`"]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return lines


def report_title(scale: str) -> str:
    """The report's title (its first heading and the page's title), naming the scale."""
    return ("Reproduction report (QUICK run: not results)" if scale == "quick"
            else f"Reproduction report ({scale} scale)")


def docs_link(report_dir: Path) -> str:
    """The relative link from a report's folder to the repository's docs/."""
    return os.path.relpath(paths.REPO_ROOT / "docs", report_dir)


def _markdown(rows: list[dict[str, str]], sidecars: dict[str, dict[str, Any]], scale: str,
              runs: Sequence[Any], figure_names: dict[str, list[str]],
              previous: dict[str, dict[str, Any]], provenance: str = "",
              docs: str = "../docs") -> str:
    when = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    source = ("a QUICK (test) run: no verdict here is a result." if scale == "quick"
              else f"a {scale}-scale run.")
    lines = [f"# {report_title(scale)}", "",
             f"Generated {when} from {source}",
             "Stand-in data and tiny models: the direction and shape of each effect is tested, "
             "never the paper's absolute numbers.", ""]
    if provenance:
        lines += [f"**Provenance.** {provenance}", ""]
    lines += trust.trust_markdown(trust.trust_rows(sidecars), f"figures/{FIGURE_NAME}",
                                  f"figures/{FOREST_NAME}", sections=sidecars)
    lines += verdicts_markdown(rows, sidecars)
    changes_by_claim = changelog.claim_changes()
    lines += trust.changes_markdown(trust.verdict_changes(sidecars, previous, changes_by_claim),
                                    changes_by_claim, docs)
    lines += errata.errata_markdown(errata.load_errata(), docs)
    lines += models_markdown(models_of(sidecars))
    if runs:
        lines += ["", "## Notebook run times", "", "| notebook | seconds |", "|---|---|"]
        lines += [f"| {r.name} | {r.seconds:.1f} |" for r in runs]
    for claim_id, sidecar in sidecars.items():
        version = sidecar.get("registry_version", 1)
        lines += ["", f'<a id="{trust.claim_anchor(claim_id)}"></a>', "",
                  f"## {claim_id} — {sidecar['verdict']} ({scale_of(sidecar)} scale)", "",
                  f"*{sidecar['statement']}* ({sidecar['paper']}, {sidecar['section']})", "",
                  f"- Rule (registry v{version}, fixed before the run): {sidecar['rule']}",
                  f"- Why: {sidecar['reason']}"]
        if part_outcomes(sidecar) and part_outcomes(sidecar) not in sidecar["reason"]:
            lines.append(f"- Parts: {part_outcomes(sidecar)}")
        lines += parts_markdown(sidecar)
        if claim_id in previous:
            lines.append(f"- Previous snapshot: {_previous_text(previous[claim_id])}")
        if _controls_line(sidecar):
            lines.append(f"- Controls: {_controls_line(sidecar)}")
        lines.append(f"- Seeds: {sidecar['seeds']}; commit {sidecar.get('commit')}")
        if sidecar.get("notes"):
            lines.append(f"- Notes: {sidecar['notes']}")
        for name in figure_names.get(claim_id, []):
            lines += ["", f"![{claim_id}](figures/{name})"]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class RecordedRun:
    """A notebook's wall time as an earlier report recorded it."""

    name: str
    seconds: float


def _recorded(claims_json: Path, key: str) -> dict[str, float]:
    try:
        seconds = read_json(claims_json).get(key, {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {str(name): float(value) for name, value in seconds.items()}


def recorded_runs(report_dir: Path) -> list[RecordedRun]:
    """The run times kept in ``report_dir/claims.json`` ([] if none)."""
    return [RecordedRun(name, value)
            for name, value in _recorded(report_dir / "claims.json", "run_seconds").items()]


def slowest_seconds(claims_json: Path) -> dict[str, float]:
    """Each notebook's slowest known wall time in a report's claims.json (``slowest_seconds``;
    older reports: ``run_seconds``) — a cold run's, once one was recorded."""
    return (_recorded(claims_json, "slowest_seconds")
            or _recorded(claims_json, "run_seconds"))


def slowest_of(*records: dict[str, float]) -> dict[str, float]:
    """Per notebook, the largest of the records' times."""
    out: dict[str, float] = {}
    for record in records:
        for name, value in record.items():
            out[name] = max(value, out.get(name, 0.0))
    return out


def write_report(build_dir: str | os.PathLike, *, scale: str,
                 runs: Sequence[Any] = (), provenance: str = "",
                 allow_mixed: bool = False) -> Path:
    """Write ``<build>/report/{REPORT.md, index.html, claims.json, figures/}``; returns the md.
    ``index.html`` is REPORT.md rendered (:func:`claims.pages.report_page`).

    ``runs``: the notebooks just run (name, seconds); the run times of the report being
    replaced are kept for the notebooks not run again (``--only``, or ``report`` alone).
    Raises :class:`ReportError` (writing nothing) when no claim is recorded, a sidecar is of
    another scale, or the claims come from several runs and ``allow_mixed`` is False.
    """
    from repro.claims.pages import report_page  # nbconvert: imported when a report is written

    build_dir = Path(build_dir)
    sidecars = load_sidecars(build_dir / "claims")
    run_line = check_runs(sidecars, scale=scale, folder=build_dir / "claims",
                          allow_mixed=allow_mixed)
    provenance = f"{provenance} {run_line}".strip()
    report_dir = build_dir / "report"
    runs = list({r.name: r for r in [*recorded_runs(report_dir), *runs]}.values())
    slowest = slowest_of(slowest_seconds(report_dir / "claims.json"),
                       {r.name: round(r.seconds, 1) for r in runs})
    figures_out = report_dir / "figures"
    figures_out.mkdir(parents=True, exist_ok=True)
    figure_names: dict[str, list[str]] = {}
    for claim_id, sidecar in sidecars.items():
        for figure in sidecar.get("figures", []):
            source = Path(figure)
            if source.is_file():
                shutil.copy2(source, figures_out / source.name)
                figure_names.setdefault(claim_id, []).append(source.name)
    claims_by_outcome(sidecars, figures_out / FIGURE_NAME)
    forest_plot(sidecars, figures_out / FOREST_NAME)
    previous = {} if scale == "quick" else trust.previous_snapshot()
    rows = _rows(sidecars, previous)
    write_json(report_dir / "claims.json", {"scale": scale,
                                            "claims": rows, "sidecars": sidecars,
                                            "run_seconds": {r.name: round(r.seconds, 1)
                                                            for r in runs},
                                            "slowest_seconds": slowest,
                                            "run_span_seconds": run_span_seconds(build_dir,
                                                                                 sidecars),
                                            "timings": kept_timings(report_dir / "claims.json",
                                                                    sidecars)})
    write_json(report_dir / "models.json", {"scale": scale,
                                            "models": models_of(sidecars),
                                            "foot_skating_ratio": skating_ratio_context()})
    markdown = _markdown(rows, sidecars, scale, runs, figure_names, previous, provenance,
                         docs_link(report_dir))
    write_text(report_dir / "index.html", report_page(markdown, report_title(scale)))
    return write_text(report_dir / "REPORT.md", markdown)


README_TABLE_START = "<!-- claims-table:start"
README_TABLE_END = "<!-- claims-table:end -->"


def readme_claims_table(rows: Sequence[dict[str, str]]) -> str:
    """The README's verdict table: claim, verdict, notebook (one row per registry claim).
    Rows with parts add, for anything but "reproduced", each part's outcome, and a verdict
    that differs from the previous snapshot's says what it was; rows of a version 1 snapshot
    (no parts) read as they always did."""
    lines = ["| claim | verdict (stand-in data, tiny models) | notebook |", "|---|---|---|"]
    for r in rows:
        verdict = r["verdict"]
        if r.get("parts_short"):
            verdict += f" — {r['parts_short']}"
        before = r.get("previous_verdict", "")
        if before and before.rsplit(" (v", 1)[0] != r["verdict"]:
            verdict += f" (was: {before})"
        lines.append(f"| {r['id']} | {verdict} | `{r['notebook']}` |")
    return "\n".join(lines)


def update_readme_table(readme: str | os.PathLike, rows: Sequence[dict[str, str]]) -> Path:
    """Rewrite the table between the README's claims-table markers (atomically)."""
    return replace_block(readme, README_TABLE_START, README_TABLE_END, readme_claims_table(rows))


#: files of ``results/`` that another command writes (``stability --snapshot``: the verdicts of
#: several base seeds side by side, which names its runs), kept when a run replaces the rest
KEPT_FROM_PREVIOUS_SNAPSHOT = ("STABILITY.md",)


def write_snapshot(build_dir: str | os.PathLike) -> Path:
    """Replace ``results/`` with the full run's REPORT.md (its "Executed notebooks" section
    added) and REPORT.html (that Markdown rendered), claims.json, PNG figures and every
    executed notebook rendered to ``notebooks/<name>.html`` (linked from both reports), and
    the README's verdict table with the same verdicts and its budgets block with the run's
    times (``claims.budgets``; ``timings``: the ``make bench`` totals in
    build/bench); ``results/STABILITY.md`` is kept (:data:`KEPT_FROM_PREVIOUS_SNAPSHOT`).
    What it writes names no path of the machine that ran the run (``paths.portable``).
    ``slowest_seconds`` keeps the slowest wall time of each notebook over the snapshots
    (``runner.longest_first`` orders by it, so a warm run's times do not hide a cold run's),
    and ``timings`` each row's newest measurement over the snapshots (a warm run keeps the
    last cold run's time beside its own)."""
    from repro.claims.pages import report_page

    report_dir = Path(build_dir) / "report"
    target = paths.results_dir()
    claims = read_json(report_dir / "claims.json")
    if claims.get("scale") != "standard":
        raise ReportError(f"{report_dir} is a {scale_of(claims)}-scale report: results/ holds "
                          "the standard scale's run only (python -m repro reproduce --scale "
                          "standard --snapshot)")
    staging = Path(tempfile.mkdtemp(prefix=".results.", dir=target.parent))
    report_text = portable((report_dir / "REPORT.md").read_text(encoding="utf-8").replace(
        f"]({docs_link(report_dir)}/", f"]({docs_link(target)}/"))
    before = target / "claims.json"
    same_scale = before.is_file() and read_json(before).get("scale") == "standard"
    claims["slowest_seconds"] = slowest_of(slowest_seconds(before) if same_scale else {},
                                         slowest_seconds(report_dir / "claims.json"))
    # each row's newest measurement: the run's own time over this build's bench over the rows
    # the previous snapshot carried (each row names its commit and CPU)
    claims["timings"] = {**(read_json(before).get("timings", {}) if same_scale else {}),
                         **bench_timings(paths.build_root() / "bench" / "bench.json"),
                         **claims.get("timings", {})}
    write_json(staging / "claims.json", portable_strings(claims))
    shutil.copy2(report_dir / "models.json", staging / "models.json")
    (staging / "figures").mkdir()
    for figure in (report_dir / "figures").glob("*.png"):
        shutil.copy2(figure, staging / "figures" / figure.name)
    pages = render_notebooks(Path(build_dir) / "notebooks", staging / "notebooks")
    report_text += notebooks_section(pages, staging)
    write_text(staging / "REPORT.md", report_text)
    write_text(staging / "REPORT.html", report_page(report_text, report_title("standard")))
    for kept in KEPT_FROM_PREVIOUS_SNAPSHOT:  # written by other commands, not by this run
        if (target / kept).is_file():
            shutil.copy2(target / kept, staging / kept)
    old = target.with_name(".results.old")
    if old.exists():
        shutil.rmtree(old)
    if target.exists():
        os.replace(target, old)
    os.replace(staging, target)
    shutil.rmtree(old, ignore_errors=True)
    snapshot = read_json(target / "claims.json")
    update_readme_table(paths.REPO_ROOT / "README.md", snapshot["claims"])
    readme = paths.REPO_ROOT / "README.md"
    if README_BUDGETS_START in readme.read_text(encoding="utf-8"):  # older READMEs have none
        update_readme_budgets(readme, snapshot)
    return target
