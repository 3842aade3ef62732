"""The claims ledger: a notebook records a claim with one call.

``record_claim`` checks that every measurement the rules need is there, applies the
registry's rule, decides the notebook's controls with the same rule, makes inconclusive the
parts held back by a model that failed a gate they read (gates version 5, ``claims.gating``),
and writes ``build/claims/<ID>.json`` atomically. The sidecar carries ``registry_version``,
the rule rendered from the settings the run used (``Claim.render_rule``: the registered
template with the run's T, stop step, strength, seeds, items, ...; ``settings`` beside
it), the verdict with its per-part outcomes (each with its interval, the effect the run
could have seen and the seeds that would see δ), each control's outcome (or "missing") and
the models; it names the run's scale (``quick``: a test of the code, never a result;
``standard`` or ``paper``), as does every model record in it. The previous snapshot's
verdict is the report's business (``claims.trust``), read from the committed
``results/claims.json``.
"""

from __future__ import annotations

import datetime as _dt
import os
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from repro.claims.gating import held_back
from repro.claims.provenance import ReportError
from repro.claims.registry import READINGS, REGISTRY_VERSION, get_claim, interval_summary
from repro.claims.verdicts import (
    INCONCLUSIVE,
    REPRODUCED,
    Decision,
    PartResult,
    apply_controls,
    combine,
    null_fired,
    parts_in_words,
)
from repro.infra import paths
from repro.infra.context import RunContext
from repro.infra.storage import read_json, write_json

CONTROLS = ("positive", "null")
#: a control's status when its claim's scale runs none of the claim's parts
NOT_RUN = "not run"
_EXPECTED = {"positive": f"{REPRODUCED} (the registered effect planted)",
             "null": f"neither {REPRODUCED} nor partially (no effect planted)",
             "aa_null": "no part supported or contradicted (an independently trained copy of "
                        "the reference arm in the other arm's place)"}


def _git_commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=paths.REPO_ROOT,
                             capture_output=True, text=True, timeout=5, check=False)
    except OSError:
        return None
    return out.stdout.strip() or None


def _control_record(claim_id: str, kind: str, measured: Mapping[str, Any] | None,
                    not_run: Mapping[str, str] | None = None, *, exact: bool = True,
                    ) -> tuple[dict[str, Any], Decision | None]:
    """A control decided by the claim's own rule over the parts the run runs, as the sidecar
    stores it; "not run" when the run's scale runs none of the claim's parts."""
    claim = get_claim(claim_id)
    if claim.parts and set(not_run or ()) >= {p.name for p in claim.parts}:
        return {"status": NOT_RUN, "expected": _EXPECTED[kind],
                "reason": "no part of the claim runs at this scale"}, None
    if measured is None:
        return {"status": "missing", "expected": _EXPECTED[kind]}, None
    decision = claim.decide(measured, not_run, control=exact)
    if not_run:   # a control sees what the run runs: its verdict over those parts alone
        ran = [p for p in claim.parts if p.name not in not_run]
        decision.verdict = combine([r for r in decision.parts if r.name not in not_run], ran)
    passed = (decision.verdict == REPRODUCED if kind == "positive"
              else not null_fired(decision, exact=exact, not_run=list(not_run or ())))
    expected = _EXPECTED[kind] if exact or kind == "positive" else _EXPECTED["aa_null"]
    return {"status": "passed" if passed else "failed", "expected": expected,
            "design": "exact" if exact else "A/A",
            "verdict": decision.verdict, "reason": decision.reason,
            "parts": [p.as_dict() for p in decision.parts], "measured": dict(measured)}, decision


def _checked_model(claim_id: str, record: Mapping[str, Any]) -> dict[str, Any]:
    missing = sorted({"name", "family", "gate", "passed"} - set(record))
    if missing:
        raise ValueError(f"{claim_id}: a model record needs {missing} (make it with "
                         "repro.core.gates.model_record)")
    reads = record.get("reads")
    parts = [p.name for p in get_claim(claim_id).parts]
    unknown = sorted(set(reads or ()) - set(parts))
    if unknown:
        raise ValueError(f"{claim_id}: model {record['name']!r} reads parts {unknown}; the "
                         f"claim's parts are {parts}")
    return dict(record)


def _gated_models(claim_id: str, models: Sequence[Mapping[str, Any]]
                  ) -> tuple[list[dict[str, Any]], dict[str, list[str]]]:
    """The model records with what each holds back under gates version 5 (``holds_back``:
    part → the failed gates that part reads of it; ``common``: part → the failed gates of a
    component every arm of that part shares, reported beside it), and gate name → the parts
    it holds back (``claims.gating.held_back`` over the registry's readings)."""
    readings = READINGS.get(claim_id, {})
    # an exact rule (EMG-1) names its parts as it decides: the registry's readings name them
    parts = [p.name for p in get_claim(claim_id).parts] or list(readings)
    gating = held_back(readings, models, parts)
    out = [{**m, **gating[m["name"]]} for m in models]
    return out, {f"model {m['name']}": sorted(m["holds_back"]) for m in out}


def _gating_notes(decision: Decision, models: Sequence[Mapping[str, Any]]) -> Decision:
    """Each part's reason with the gates behind it: the failed gates it reads of a model that
    holds it back, and those of the components its arms share (reported, never gating)."""
    notes: dict[str, list[str]] = {}
    for model in models:
        for part, failed in (model.get("holds_back") or {}).items():
            notes.setdefault(part, []).append(f"held back by {model['name']} "
                                              f"({', '.join(failed)})")
        for part, failed in (model.get("common") or {}).items():
            notes.setdefault(part, []).append(f"shared by every arm, reported, not gating: "
                                              f"{model['name']} fails {', '.join(failed)}")
    if not notes:
        return decision
    parts = [PartResult(p.name, p.outcome, f"{p.reason}; {'; '.join(notes[p.name])}", p.numbers)
             if p.name in notes else p for p in decision.parts]
    return Decision(decision.verdict, decision.reason, dict(decision.checks), parts)


def decide_claim(claim_id: str, measured: Mapping[str, Any], *,
                 controls: Mapping[str, Mapping[str, Any]] | None = None,
                 quality_gates: Mapping[str, bool] | None = None,
                 gate_reads: Mapping[str, Sequence[str] | None] | None = None,
                 not_measurable: str | None = None,
                 not_run: Mapping[str, str] | None = None,
                 controls_exact: bool = True,
                 ) -> tuple[Decision, dict[str, Any]]:
    """(the decision after controls and gates, the controls as stored); ``controls_exact``:
    the controls are paired draws with δ planted exactly (True) or A/A runs of independently
    trained models (False: decided by the claim's own rule, the null failing when any part
    comes out supported or contradicted, ``verdicts.null_fired``); ``gate_reads``: the
    parts each gate's model is read by (absent: every part). ``not_measurable``: why the
    run's data cannot give the rule's measurements (e.g. "not measurable on real data: ...");
    then nothing is required, every part is inconclusive with that reason, and so is the
    claim (its controls are recorded as missing). ``not_run``: part → why the run's scale
    does not run it (a registered cut, in words); those parts are inconclusive with it, the
    measurements only they read are not required, and the controls are decided over the
    parts that run."""
    claim = get_claim(claim_id)
    unknown_parts = sorted(set(not_run or ()) - {p.name for p in claim.parts})
    if unknown_parts:
        raise ValueError(f"{claim_id}: parts not run {unknown_parts} are not its parts "
                         f"{[p.name for p in claim.parts]}")
    if not_measurable is not None:
        stored = {kind: _control_record(claim_id, kind, None)[0] for kind in CONTROLS}
        parts = [PartResult(p.name, INCONCLUSIVE, not_measurable) for p in claim.parts]
        return Decision(INCONCLUSIVE, not_measurable, {p.name: p.outcome for p in parts},
                        parts), stored
    missing = sorted(claim.required_measurements(list(not_run or ())) - set(measured))
    if missing:
        raise ValueError(f"{claim_id}: the rule needs measurements {missing}; got "
                         f"{sorted(measured)}")
    unknown = sorted(set(controls or {}) - set(CONTROLS))
    if unknown:
        raise ValueError(f"{claim_id}: controls are {CONTROLS}; got {unknown}")
    stored, decided = {}, {}
    for kind in CONTROLS:
        stored[kind], decided[kind] = _control_record(claim_id, kind, (controls or {}).get(kind),
                                                      not_run, exact=controls_exact)
    decision = apply_controls(claim.decide(measured, not_run), decided, quality_gates,
                              gate_reads, claim.parts, not_run=list(not_run or ()),
                              exact_controls=controls_exact)
    return decision, stored


def record_claim(ctx: RunContext, claim_id: str, measured: Mapping[str, Any], **kwargs: Any,
                 ) -> Decision:
    """Apply the registered rules of ``claim_id`` to ``measured`` and write its sidecar
    (:func:`record_claim_and_controls`'s arguments; its decision)."""
    return record_claim_and_controls(ctx, claim_id, measured, **kwargs)[0]


def rule_settings(seeds: Sequence[int], settings: Mapping[str, Any] | None
                  ) -> dict[str, Any]:
    """The settings a rule is rendered from: the experiment's ``settings`` and, as
    ``seeds``, how many seeds the run recorded (the seed list is what the run used)."""
    return {**(settings or {}), "seeds": len(seeds)}


def rendered_rule(claim_id: str, seeds: Sequence[int],
                  settings: Mapping[str, Any] | None) -> str:
    """``claim_id``'s rule with the run's settings in it (:func:`rule_settings`); a
    ``claim.MissingRuleSetting`` when the template names a setting not given."""
    return get_claim(claim_id).render_rule(rule_settings(seeds, settings))


def record_claim_and_controls(ctx: RunContext, claim_id: str, measured: Mapping[str, Any], *,
                              seeds: Sequence[int],
                              settings: Mapping[str, Any] | None = None,
                              controls: Mapping[str, Mapping[str, Any]] | None = None,
                              quality_gates: Mapping[str, bool] | None = None,
                              models: Sequence[Mapping[str, Any]] = (),
                              figures: Sequence[str | os.PathLike] = (), notes: str = "",
                              headline: str = "",
                              extra: Mapping[str, Any] | None = None,
                              not_measurable: str | None = None,
                              not_run: Mapping[str, str] | None = None,
                              controls_exact: bool = True,
                              ) -> tuple[Decision, dict[str, dict[str, Any]]]:
    """Apply the registered rules of ``claim_id`` to ``measured`` and write its sidecar; the
    decision and each control as the sidecar stores it.

    Args:
        ctx: the run (its scale, run ID and claims folder); a quick run's verdict is recorded
            but never reported as a result.
        claim_id: an ID from the registry (unknown IDs raise ValueError listing the known ones).
        measured: every measurement the rules name (missing ones raise ValueError; a
            ``new_measurements`` one makes its part inconclusive instead).
        seeds: the seeds behind per-seed lists.
        settings: what the run used that the rule's text quotes (``Claim.rule_fields``: T, the
            stop step, the guidance strength, items, ...), read from the experiment's own
            settings; the number of seeds is ``len(seeds)``. A field the template names and
            ``settings`` lacks raises ``claim.MissingRuleSetting`` before anything is written.
        controls: ``{"positive": measured, "null": measured}`` from the notebook's control
            experiments (the registered effect planted / no effect), decided by the same
            rule: a positive control that is not reproduced or a null control that comes out
            reproduced or partially makes the claim inconclusive. Missing controls are
            recorded as missing, not an error.
        controls_exact: False when the controls are A/A runs of independently trained
            models: decided by the claim's own rule, the null failing when any part comes
            out supported or contradicted (``decide_claim``).
        quality_gates: gate name → passed, for what the measurements rest on beyond the
            models; a failed one makes every part inconclusive.
        models: the trained models behind the measurements, each a
            ``repro.core.gates.model_record`` (family, fitness-gate values against their
            registered bounds, steps, training time, ``reads``: the claim's parts that rest
            on it, None for every part); a model that fails its gate makes those parts
            inconclusive (``quality_gates`` gains ``model <name>``), and the report's "Models"
            section and ``models.json`` list every model with the claims that use it.
        figures: paths of the figures that show the claim.
        notes: what the notebook chose where the paper is silent, caveats.
        headline: one line of our key numbers for the report's table (default: derived).
        extra: further numbers to keep beside the rule's inputs (tables, paper rows).
        not_measurable: why the run's data cannot give the measurements (``decide_claim``);
            the sidecar then keeps it as ``not_measurable`` (absent otherwise).
        not_run: part → why the run's scale does not run it (the paper package's registered
            cuts, e.g. ``gmd.settings.not_run``); each such part is inconclusive, "not run at
            the <scale> scale: <why>", and the sidecar keeps them as ``not_run``.
    """
    claim = get_claim(claim_id)
    rule = rendered_rule(claim_id, seeds, settings)
    models = [{**_checked_model(claim_id, m), "scale": ctx.scale} for m in models]
    models, reads = _gated_models(claim_id, models)
    gates = {**(quality_gates or {}), **{f"model {m['name']}": not m["holds_back"]
                                         for m in models}}
    cut = {part: f"not run at the {ctx.scale} scale: {why}"
           for part, why in (not_run or {}).items()}
    decision, stored_controls = decide_claim(claim_id, measured, controls=controls,
                                             quality_gates=gates or None, gate_reads=reads,
                                             not_measurable=not_measurable, not_run=cut,
                                             controls_exact=controls_exact)
    decision = _gating_notes(decision, models)
    sidecar = {
        "id": claim.id,
        "registry_version": REGISTRY_VERSION,
        "paper": claim.paper,
        "section": claim.section,
        "statement": claim.statement,
        "paper_value": claim.paper_value,
        "notebook": claim.notebook,
        "rule": rule,
        "settings": rule_settings(seeds, settings),
        "verdict": decision.verdict,
        "reason": decision.reason,
        "checks": decision.checks,
        "parts": [p.as_dict() for p in decision.parts],
        "controls": stored_controls,
        "quality_gates": gates,
        "models": models,
        "measured": dict(measured),
        "summary": interval_summary(dict(measured)),
        "extra": dict(extra or {}),
        "seeds": list(seeds),
        "scale": ctx.scale,
        "run_id": ctx.run_id,
        "figures": [str(Path(f).resolve()) for f in figures],
        "notes": notes,
        "headline": headline,
        "recorded_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _git_commit(),
    }
    if not_measurable is not None:
        sidecar["not_measurable"] = not_measurable
    if cut:
        sidecar["not_run"] = cut
    write_json(ctx.claims_dir / f"{claim.id}.json", sidecar)
    return decision, stored_controls


def load_sidecars(directory: str | os.PathLike) -> dict[str, dict[str, Any]]:
    """Every recorded claim in ``directory`` (a run's ``claims/`` folder)."""
    folder = Path(directory)
    if not folder.is_dir():
        return {}
    return {p.stem: read_sidecar(p) for p in sorted(folder.glob("*.json"))}


def read_sidecar(path: Path) -> dict[str, Any]:
    """One sidecar; a garbled one raises :class:`ReportError` naming it and the fix."""
    try:
        sidecar = read_json(path)
    except (ValueError, UnicodeDecodeError) as error:  # JSONDecodeError is a ValueError
        problem = f"is not valid JSON ({error})"
    else:
        if isinstance(sidecar, dict):
            return sidecar
        problem = f"holds a JSON {type(sidecar).__name__}, not a claim's record"
    raise ReportError(f"the claim sidecar {path} {problem}: delete it and record the claim "
                      f"again (python -m repro reproduce --only {path.stem} --scale SCALE, "
                      "the scale of the run whose folder holds it), or restore it from a copy")


def part_outcomes(sidecar: dict[str, Any], *, reasons: bool = True) -> str:
    """A sidecar's per-part outcomes in words, for anything but "reproduced" ("" for a
    reproduced claim and for a version 1 sidecar, which has no parts)."""
    if sidecar.get("verdict") == REPRODUCED or not sidecar.get("parts"):
        return ""
    return parts_in_words(sidecar["parts"], reasons=reasons)


def verdict_markdown(ctx: RunContext, claim_id: str, decision: Decision, rule: str) -> str:
    """A short markdown block for the notebook's verdict cell; ``rule``: the rule as the run
    rendered it (:func:`rendered_rule`)."""
    claim = get_claim(claim_id)
    mode = " *(quick run: a test of the code, not a result)*" if ctx.quick else ""
    lines = [f"**{claim.id} — {decision.verdict}**{mode}", "",
             f"*Rule (registry v{REGISTRY_VERSION}, fixed before the run; this run's settings "
             f"in it):* {rule}", "", f"*Why:* {decision.reason}"]
    return "\n".join(lines)
