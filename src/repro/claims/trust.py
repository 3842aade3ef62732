"""How far each verdict can be trusted: the first screen of REPORT.md.

Per registry claim, from its sidecar: the verdict; the parts' outcomes counted (supported,
contradicted, absent, inconclusive, below resolution; ``repro.claims.verdicts``); the controls
(was the planted effect seen, did the null stay silent); whether the models behind it passed
their fitness gates (``models``, ``quality_gates``); and what limits it — power (inconclusive
parts whose run could not see δ: the minimum detectable effect each part records), resolution
(parts below it), a failed or missing control or gate, and the stand-in data. Then the verdict
changes since the previous snapshot (the committed ``results/claims.json`` when the report is
written), with the registry changelog's reasons for the versions in between.
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from repro.claims.changelog import EVERY_CLAIM, Change
from repro.claims.claim import Claim
from repro.claims.ledger import NOT_RUN
from repro.claims.provenance import is_result, scale_of
from repro.claims.registry import CLAIMS, REGISTRY_VERSION
from repro.claims.verdicts import BELOW_RESOLUTION, INCONCLUSIVE, OUTCOMES, VERDICTS
from repro.infra import paths
from repro.infra.storage import read_json

NOT_TESTED = "not yet tested"
QUICK = "quick run (not a result)"
#: where a failed gate's numbers are: the report's "Models" section (GitHub's anchor of it)
SEE_MODELS = "(see [Models](#models))"


@dataclass(frozen=True)
class TrustRow:
    """One claim on the trust screen; every field is short words."""

    claim_id: str
    verdict: str
    parts: str
    controls: str
    models: str
    limits: str
    outcome_counts: dict[str, int]


def outcome_counts(sidecar: Mapping[str, Any]) -> dict[str, int]:
    """How many of the sidecar's parts came out each way (registry order of outcomes)."""
    counts = Counter(p["outcome"] for p in sidecar.get("parts", []))
    return {outcome: counts[outcome] for outcome in OUTCOMES if counts[outcome]}


def parts_text(counts: Mapping[str, int]) -> str:
    """"2 supported, 1 inconclusive": the counts of :func:`outcome_counts` in words."""
    return ", ".join(f"{n} {outcome}" for outcome, n in counts.items()) or "—"


def _has_controls(claim: Claim, sidecar: Mapping[str, Any]) -> bool:
    """A claim decided on effects, or an exact check that records its controls (EMG-1's: a
    trained model's field made a gradient field, and one twice the tolerance away)."""
    controls = sidecar.get("controls") or {}
    return claim.rests_on_effects or any(
        (controls.get(kind) or {}).get("status") in ("passed", "failed")
        for kind in ("positive", "null"))


def controls_text(claim: Claim, sidecar: Mapping[str, Any]) -> str:
    """"positive seen, null silent" and the like; "—" for exact checks without controls (no
    effect to plant)."""
    if not _has_controls(claim, sidecar):
        return "— (exact check)"
    controls = sidecar.get("controls") or {}
    words = {"positive": {"passed": "positive seen", "failed": "positive **missed**"},
             "null": {"passed": "null silent", "failed": "null **fired**"}}
    if all((controls.get(kind) or {}).get("status") == NOT_RUN for kind in ("positive", "null")):
        return "not run at this scale"
    out = []
    for kind in ("positive", "null"):
        status = (controls.get(kind) or {}).get("status", "missing")
        out.append(words[kind].get(status, f"no {kind} control"))
    return ", ".join(out)


def _running_parts(sidecar: Mapping[str, Any]) -> set[str]:
    """The claim's parts its run's scale runs (all but the sidecar's ``not_run``)."""
    return {p["name"] for p in sidecar.get("parts", [])} - set(sidecar.get("not_run") or {})


def _runs_nothing(sidecar: Mapping[str, Any]) -> bool:
    """A claim with parts, none of which its run's scale runs."""
    return bool(sidecar.get("not_run")) and not _running_parts(sidecar)


def gates_text(claim: Claim, sidecar: Mapping[str, Any]) -> str:
    """"3/3 pass" or "**1 of 3 fail**" (linked to the report's Models section) over the
    sidecar's quality gates (each model's gate is one of them); "none recorded" when a
    measured claim has none; a claim none of whose parts runs says so (its models, if any, are
    shown but decide nothing: their failures are not in bold)."""
    gates = dict(sidecar.get("quality_gates") or {})
    for model in sidecar.get("models", []):
        gates.setdefault(f"model {model['name']}", _model_ok(model))
    idle = "; no part runs" if _runs_nothing(sidecar) else ""
    if not gates:
        if idle:
            return "— (not run at this scale)"
        return "— (no model)" if not claim.rests_on_effects else "none recorded"
    failed = [name for name, passed in gates.items() if not passed]
    if failed and idle:   # shown, deciding nothing: not in bold
        return f"{len(failed)} of {len(gates)} fail {SEE_MODELS}, deciding nothing{idle}"
    if failed:
        return f"**{len(failed)} of {len(gates)} fail** {SEE_MODELS}"
    unread = sum(not m["passed"] for m in sidecar.get("models", []))
    if unread:   # gates version 5: failures no part reads of that model, reported
        return (f"{len(gates)}/{len(gates)} hold back no part; {unread} fail a gate no part "
                f"reads of them {SEE_MODELS}{idle}")
    return f"{len(gates)}/{len(gates)} pass{idle}"


def power_short(sidecar: Mapping[str, Any]) -> str:
    """"power (k of n parts: this run could see 2.1–40× δ)" over the inconclusive parts whose
    minimum detectable effect (recorded per comparison) exceeds δ, a part measured on one
    seed (no interval: nothing it could see) as "one seed"; "" if none."""
    ratios, single = [], 0
    for part in sidecar.get("parts", []):
        if part["outcome"] != INCONCLUSIVE:
            continue
        rows = [r for r in (part.get("numbers") or {}).values() if isinstance(r, dict)
                and r.get("smallest_effect") and "minimum_detectable_effect" in r]
        seen = [r["minimum_detectable_effect"] / abs(r["smallest_effect"]) for r in rows]
        if not all(map(math.isfinite, seen)):   # fewer than two seeds: no interval
            single += 1
        elif seen and max(seen) > 1.0:
            ratios.append(max(seen))
    if not ratios and not single:
        return ""
    words = []
    if ratios:
        low, high = f"{min(ratios):.2g}", f"{max(ratios):.2g}"
        words.append(f"this run could see {low if low == high else f'{low}–{high}'}× δ")
    if single:
        words.append(f"{'one part' if single == 1 else f'{single} parts'} on one seed, "
                     "which decides no direction")
    return (f"power ({len(ratios) + single} of {len(sidecar.get('parts', []))} parts: "
            f"{'; '.join(words)})")


def unmeasured_short(sidecar: Mapping[str, Any]) -> str:
    """"not measured by this run (part, ...)" over the parts whose measurement the run did
    not record (a value its scale does not run); "" if none."""
    missing = [p["name"] for p in sidecar.get("parts", [])
               if p["outcome"] == INCONCLUSIVE and ("not recorded" in p.get("reason", "")
                                                    or p.get("reason", "").startswith("not run"))]
    return f"not measured by this run ({', '.join(missing)})" if missing else ""


def _controls_short(claim: Claim, sidecar: Mapping[str, Any]) -> bool:
    """A measured claim whose controls are missing or failed (not a claim its scale does not
    run: its controls are "not run", and its parts say why)."""
    controls = sidecar.get("controls") or {}
    return _has_controls(claim, sidecar) and any(
        (controls.get(kind) or {}).get("status") not in ("passed", NOT_RUN)
        for kind in ("positive", "null"))


def _model_ok(model: Mapping[str, Any]) -> bool:
    """A model holds back none of the claim's parts (gates version 5; before it: passed)."""
    return not model["holds_back"] if "holds_back" in model else bool(model["passed"])


def _gates(sidecar: Mapping[str, Any]) -> dict[str, bool]:
    gates = dict(sidecar.get("quality_gates") or {})
    gates.update({m["name"]: _model_ok(m) for m in sidecar.get("models", [])})
    return gates


def _deciding_gates(sidecar: Mapping[str, Any]) -> dict[str, bool]:
    """The gates a running part rests on: every quality gate but a model's read only by
    parts its scale does not run (``reads``: None, every part)."""
    running = _running_parts(sidecar)
    if not sidecar.get("not_run"):
        return _gates(sidecar)
    if not running:
        return {}
    gates = {k: v for k, v in (sidecar.get("quality_gates") or {}).items()
             if not k.startswith("model ")}
    gates.update({m["name"]: _model_ok(m) for m in sidecar.get("models", [])
                  if m.get("reads") is None or set(m["reads"]) & running})
    return gates


def _gates_short(claim: Claim, sidecar: Mapping[str, Any]) -> bool:
    """A measured claim with no gate recorded; any claim with a gate (or model) that
    failed and that a part its scale runs rests on; never a claim none of whose parts runs
    (its parts say why)."""
    if _runs_nothing(sidecar):
        return False
    return ((claim.rests_on_effects and not _gates(sidecar))
            or not all(_deciding_gates(sidecar).values()))


def limits_text(claim: Claim, sidecar: Mapping[str, Any]) -> str:
    """What limits the verdict: power, resolution, a control or gate, the stand-in; first, a
    sidecar recorded under another registry version."""
    limits = []
    version = int(sidecar.get("registry_version", 1))
    if version != REGISTRY_VERSION:
        limits.append(f"decided under registry v{version}, not v{REGISTRY_VERSION}")
    if unmeasured_short(sidecar):
        limits.append(unmeasured_short(sidecar))
    if power_short(sidecar):
        limits.append(power_short(sidecar))
    below = [p["name"] for p in sidecar.get("parts", []) if p["outcome"] == BELOW_RESOLUTION]
    if below:
        limits.append(f"resolution ({', '.join(below)})")
    if _controls_short(claim, sidecar):
        limits.append("controls")
    if _gates_short(claim, sidecar):
        limits.append("quality gates")
    if claim.rests_on_effects:
        limits.append("stand-in data, tiny models")
    elif _gates(sidecar):
        limits.append("stand-in data, tiny models (an exact measurement of trained models)")
    else:
        limits.append("none (an exact computation, no trained model)")
    return "; ".join(limits)


def trust_rows(sidecars: Mapping[str, Mapping[str, Any]]) -> list[TrustRow]:
    """One row per registry claim, in registry order. A quick run's rows show its parts,
    controls and gates (a test of the machinery) but never its verdict."""
    rows = []
    for claim in CLAIMS.values():
        sidecar = sidecars.get(claim.id)
        if sidecar is None:
            rows.append(TrustRow(claim.id, NOT_TESTED, "—", "—", "—", "—", {}))
            continue
        counts = outcome_counts(sidecar)
        controls, gates = controls_text(claim, sidecar), gates_text(claim, sidecar)
        verdict = sidecar["verdict"] if is_result(sidecar) else QUICK
        rows.append(TrustRow(claim.id, verdict, parts_text(counts), controls, gates,
                             limits_text(claim, sidecar), counts))
    return rows


def verdict_counts(rows: list[TrustRow]) -> dict[str, int]:
    counts = Counter(r.verdict for r in rows)
    return {v: counts[v] for v in (*VERDICTS, QUICK, NOT_TESTED) if counts[v]}


def claim_anchor(claim_id: str) -> str:
    """The anchor of a claim's section in the report (``GMD-A3`` → ``gmd-a3``)."""
    return claim_id.lower()


def claim_link(claim_id: str, sections: Collection[str], text: str | None = None) -> str:
    """``[text](#gmd-a3)`` when the report has ``claim_id``'s section, else the text."""
    text = text or claim_id
    return f"[{text}](#{claim_anchor(claim_id)})" if claim_id in sections else text


def trust_markdown(rows: list[TrustRow], figure: str | None = None,
                   forest: str | None = None, sections: Collection[str] = ()) -> list[str]:
    """The report's opening screen: counts, the forest plot of every part (``forest``), the
    per-claim trust table (a claim in ``sections`` linked to its section), the outcome
    figure's link."""
    counts = ", ".join(f"{n} {v}" for v, n in verdict_counts(rows).items())
    lines = ["## How far each verdict can be trusted", "",
             f"{len(rows)} claims: {counts} (registry v{REGISTRY_VERSION})."]
    if forest:
        lines += ["", f"![Every part's effect in units of its δ, with its interval]({forest})",
                  "", "*Every part at a glance: its mean per-seed effect (a difference, or a "
                  "log ratio where δ is a fraction of an arm) over its smallest effect of "
                  "interest δ, with the 95 % interval; the grey band is ±δ; the colour is the "
                  "part's outcome. Each claim's parts, with what the run could see, are in "
                  "its section below.*"]
    lines += ["", "Parts: each registered part's outcome. Controls: the claim's own rule on a "
              "planted effect (must be seen) and on no effect (must stay silent), their arms "
              "paired as the experiment's (what the seeds could see is each part's own "
              "minimum detectable effect). Gates: the "
              "models behind the measurements against their registered fitness gates. A null "
              "control that fires makes a verdict inconclusive; a missed positive control, "
              "the parts that were not significant; a failed gate, the parts that read its "
              "model.", "",
              "| claim | verdict | parts | controls | gates | limited by |",
              "|---|---|---|---|---|---|"]
    for r in rows:
        cells = [claim_link(r.claim_id, sections), f"**{r.verdict}**", r.parts, r.controls,
                 r.models, r.limits]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    if figure:
        lines += ["", f"![The {len(rows)} claims by outcome]({figure})"]
    return lines + [""]


def previous_snapshot(path: str | os.PathLike | None = None) -> dict[str, dict[str, Any]]:
    """Claim ID → ``verdict``, ``registry_version`` and ``run_id`` of the committed snapshot's
    full-run sidecars (``results/claims.json``, or ``path``); {} without one."""
    try:
        sidecars = read_json(path or paths.results_dir() / "claims.json").get("sidecars", {})
    except (OSError, ValueError, AttributeError):
        return {}
    return {claim_id: {"verdict": s["verdict"],
                       "registry_version": int(s.get("registry_version", 1)),
                       "run_id": s.get("run_id"), "scale": scale_of(s)}
            for claim_id, s in sidecars.items() if is_result(s) and "verdict" in s}


@dataclass(frozen=True)
class VerdictChange:
    """A claim whose verdict differs from the previous snapshot's, with the changelog bullets
    of the registry versions after the one that snapshot was decided under."""

    claim_id: str
    previous: str
    previous_version: int
    current: str
    changes: list[Change]


def verdict_changes(sidecars: Mapping[str, Mapping[str, Any]],
                    previous: Mapping[str, Mapping[str, Any]],
                    changelog: Mapping[str, list[Change]]) -> list[VerdictChange]:
    """Every full-run claim whose verdict differs from the previous snapshot's."""
    out = []
    for claim_id in CLAIMS:
        sidecar, before = sidecars.get(claim_id), previous.get(claim_id)
        if sidecar is None or not is_result(sidecar) or before is None:
            continue
        if before["verdict"] != sidecar["verdict"]:
            version = int(before["registry_version"])
            out.append(VerdictChange(claim_id, before["verdict"], version, sidecar["verdict"],
                                     [c for c in changelog.get(claim_id, [])
                                      if c.version > version]))
    return out


def _cite(change: Change, docs: str) -> str:
    return (f"[v{change.version}: {change.section}]({docs}/REGISTRY_CHANGELOG.md"
            f"#{change.anchor})")


def changes_markdown(changes: list[VerdictChange], changelog: Mapping[str, list[Change]],
                     docs: str = "../docs") -> list[str]:
    """The "Verdict changes since the previous snapshot" section; ``docs``: the link from the
    report's folder to the repository's docs/."""
    lines = ["", "## Verdict changes since the previous snapshot", ""]
    if not changes:
        return lines + ["No full-run verdict here differs from the previous snapshot's (the "
                        "committed `results/` when this report was written; quick runs have "
                        "none to compare).", ""]
    oldest = min(c.previous_version for c in changes)
    every = [c for c in changelog.get(EVERY_CLAIM, []) if c.version > oldest]
    lines += [f"{len(changes)} verdicts differ from the previous snapshot's. A change comes "
              "from new measurements (another run, models or design) or from a change of rule "
              f"(quoted from [the registry changelog]({docs}/REGISTRY_CHANGELOG.md) for the "
              "versions after the snapshot's"
              + (f"; the rules of every claim changed too: "
                 f"{', '.join(dict.fromkeys(_cite(c, docs) for c in every))}" if every else "")
              + ").", ""]
    for c in changes:
        reasons = " ".join(f"{ch.text} ({_cite(ch, docs)})" for ch in c.changes) or (
            "no bullet of the changelog names this claim after the snapshot's version.")
        lines.append(f"- **{c.claim_id}**: v{c.previous_version} *{c.previous}* → "
                     f"v{REGISTRY_VERSION} *{c.current}*. {reasons}")
    return lines + [""]
