"""What an experiment returns and how a notebook records and shows it.

Every paper package's experiment ends in a :class:`ClaimResult`: the measurements the
registered rule reads, the two controls (:class:`Controls`: the registered effect planted, no
effect), the models behind the measurements, the figures, the headline and the notes. A
notebook cell then does three things: call the experiment, ``record(ctx, result)`` (the
ledger's rule, controls and gates: :func:`repro.claims.ledger.record_claim`), and display
:func:`recorded_markdown` — the verdict and the controls' table, one renderer for both papers.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from repro.claims.ledger import (
    CONTROLS,
    record_claim_and_controls,
    rendered_rule,
    verdict_markdown,
)
from repro.claims.verdicts import Decision, parts_in_words
from repro.core.tables import markdown_table
from repro.infra.context import RunContext

__all__ = ["ClaimResult", "Controls", "Recorded", "controls_markdown", "not_measurable_result",
           "record",
           "recorded_markdown", "summary_markdown"]

#: what each control arm is when an experiment gives no words of its own
_DEFAULT_ARMS = {"positive": "the registered δ planted", "null": "no effect"}
_MUST_BE = {"positive": "reproduced", "null": "neither reproduced nor partially"}


@dataclass
class Controls:
    """A claim's two controls as the ledger decides them: the measurements of the positive
    control (every part's registered effect planted) and of the null control (no effect),
    what was planted, and each control's arms in words rendered from the planted sizes."""

    null: dict[str, Any]
    positive: dict[str, Any]
    planted: dict[str, Any] = field(default_factory=dict)
    null_text: str = ""
    positive_text: str = ""
    #: True: arms built on the same draws with δ planted exactly (decided by sign where every
    #: seed gives the same difference, ``verdicts.exact_differences``); False: an A/A control
    #: of independently trained models, whose differences are decided by the claim's own rule
    exact: bool = True

    def as_controls(self) -> dict[str, dict[str, Any]]:
        """The ``controls=`` argument of ``record_claim``."""
        return {"positive": self.positive, "null": self.null}


@dataclass
class ClaimResult:
    """One claim's experiment, as ``record_claim`` takes it (its arguments, by name).

    ``settings``: what the run used that the claim's rule quotes (T, the stop step, the
    guidance strength, items, ...; ``Claim.rule_fields``), read from the experiment's own
    settings object (the paper packages' ``settings.RULE_SETTINGS``), never typed."""

    claim_id: str
    measured: dict[str, Any]
    seeds: Sequence[int]
    settings: Mapping[str, Any] = field(default_factory=dict)
    controls: Controls | None = None
    models: Sequence[Mapping[str, Any]] = ()
    figures: Sequence[str | os.PathLike] = ()
    headline: str = ""
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)
    quality_gates: Mapping[str, bool] | None = None
    #: why the run's data cannot give the measurements (``ledger.decide_claim``); None: measured
    not_measurable: str | None = None
    #: part → why the run's scale does not run it (a registered cut; ``ledger.decide_claim``)
    not_run: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Recorded:
    """A recorded claim: its decision and each control as the sidecar stores it."""

    result: ClaimResult
    decision: Decision
    controls: dict[str, dict[str, Any]]

    @property
    def verdict(self) -> str:
        return self.decision.verdict

    @property
    def reason(self) -> str:
        return self.decision.reason


def not_measurable_result(claim_id: str, reason: str, seeds: Sequence[int], *,
                          settings: Mapping[str, Any], models: Sequence[Mapping[str, Any]] = ()
                          ) -> ClaimResult:
    """A claim whose measurement cannot be made on the run's data (e.g. it needs the stand-in's
    concept labels and the run was given a real data folder): nothing measured, every part
    and the claim inconclusive with ``reason`` (which says "not measurable on real data" and
    why; also its headline and notes, and the sidecar's ``not_measurable``). No number is
    made up. ``settings``: the run's, as for a measured claim (its rule still says what the
    run was set to do)."""
    return ClaimResult(claim_id, {}, seeds=seeds, settings=settings, models=models,
                       headline=reason, notes=reason, not_measurable=reason)


def record(ctx: RunContext, result: ClaimResult) -> Recorded:
    """Decide ``result`` by its registered rule, controls and gates and write its sidecar."""
    controls = result.controls.as_controls() if result.controls is not None else None
    decision, stored = record_claim_and_controls(
        ctx, result.claim_id, result.measured, seeds=result.seeds, settings=result.settings,
        controls=controls,
        controls_exact=result.controls.exact if result.controls is not None else True,
        quality_gates=result.quality_gates, models=result.models, figures=result.figures,
        notes=result.notes, headline=result.headline, extra=result.extra,
        not_measurable=result.not_measurable, not_run=result.not_run or None)
    return Recorded(result, decision, stored)


def controls_markdown(claim_id: str, stored: Mapping[str, Mapping[str, Any]],
                      controls: Controls | None = None) -> str:
    """The two controls beside a verdict, one row each: what its arms are, what it must come
    out as, its verdict under the claim's rule, passed or failed, and its parts."""
    texts = {"positive": controls.positive_text, "null": controls.null_text} if controls else {}
    rows = []
    for kind in CONTROLS:
        found = stored[kind]
        rows.append([kind, texts.get(kind) or _DEFAULT_ARMS[kind], _MUST_BE[kind],
                     found.get("verdict", "—"), found["status"],
                     parts_in_words(found.get("parts", []))])
    return (f"**{claim_id} controls**\n\n"
            + markdown_table(["control", "arms", "must be", "verdict (same rule)", "outcome",
                              "parts"], rows))


def recorded_markdown(ctx: RunContext, recorded: Recorded) -> str:
    """The notebook's verdict block: the verdict with its rule and reason, then the controls
    (a claim without a model-based measurement has none: its block ends with the reason)."""
    claim_id = recorded.result.claim_id
    rule = rendered_rule(claim_id, recorded.result.seeds, recorded.result.settings)
    verdict = verdict_markdown(ctx, claim_id, recorded.decision, rule)
    if recorded.result.controls is None:
        return verdict
    return (verdict + "\n\n"
            + controls_markdown(claim_id, recorded.controls, recorded.result.controls))


def summary_markdown(ctx: RunContext, recorded: Sequence[Recorded]) -> str:
    """A notebook's closing summary: each claim's verdict and reason (a quick run says that it
    is not a result)."""
    mode = " (quick run: not a result)" if ctx.quick else ""
    return f"### Summary{mode}\n\n" + "\n".join(
        f"- **{r.result.claim_id}**: {r.verdict} — {r.reason}" for r in recorded)
