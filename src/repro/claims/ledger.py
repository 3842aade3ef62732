"""The claims ledger: a notebook records a claim with one call.

``record_claim`` checks that every measurement the rule needs is there, applies the rule from
the registry (written before the run), and writes ``build/claims/<ID>.json`` atomically. The
sidecar says whether the run was ``quick`` (a test of the code, never a result) or ``full``.
"""

from __future__ import annotations

import datetime as _dt
import os
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from repro.claims.registry import get_claim, interval_summary
from repro.claims.verdicts import Decision
from repro.infra import paths
from repro.infra.context import RunContext
from repro.infra.storage import read_json, write_json

MODES = ("quick", "full")


def _git_commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=paths.REPO_ROOT,
                             capture_output=True, text=True, timeout=5, check=False)
    except OSError:
        return None
    return out.stdout.strip() or None


def record_claim(ctx: RunContext, claim_id: str, measured: Mapping[str, Any], *,
                 seeds: Sequence[int], figures: Sequence[str | os.PathLike] = (),
                 notes: str = "", headline: str = "",
                 extra: Mapping[str, Any] | None = None) -> Decision:
    """Apply the registered rule of ``claim_id`` to ``measured`` and write its sidecar.

    Args:
        ctx: the run (its mode, run ID and claims folder); a quick run's verdict is recorded
            but never reported as a result.
        claim_id: an ID from the registry (unknown IDs raise ValueError listing the known ones).
        measured: every measurement the rule names (missing ones raise ValueError).
        seeds: the seeds behind per-seed lists.
        figures: paths of the figures that show the claim.
        notes: what the notebook chose where the paper is silent, caveats.
        headline: one line of our key numbers for the report's table (default: derived).
        extra: further numbers to keep beside the rule's inputs (tables, paper rows).
    """
    claim = get_claim(claim_id)
    missing = sorted(set(claim.measurements) - set(measured))
    if missing:
        raise ValueError(f"{claim_id}: the rule needs measurements {missing}; got "
                         f"{sorted(measured)}")
    decision = claim.decide(measured)
    sidecar = {
        "id": claim.id,
        "paper": claim.paper,
        "section": claim.section,
        "statement": claim.statement,
        "paper_value": claim.paper_value,
        "notebook": claim.notebook,
        "rule": claim.rule,
        "verdict": decision.verdict,
        "reason": decision.reason,
        "checks": decision.checks,
        "measured": dict(measured),
        "summary": interval_summary(dict(measured)),
        "extra": dict(extra or {}),
        "seeds": list(seeds),
        "mode": ctx.mode,
        "run_id": ctx.run_id,
        "figures": [str(Path(f).resolve()) for f in figures],
        "notes": notes,
        "headline": headline,
        "recorded_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "commit": _git_commit(),
    }
    write_json(ctx.claims_dir / f"{claim.id}.json", sidecar)
    return decision


def load_sidecars(directory: str | os.PathLike | None = None) -> dict[str, dict[str, Any]]:
    """Every recorded claim in ``directory`` (default: the build's claims folder)."""
    folder = Path(directory) if directory is not None else paths.claims_dir()
    if not folder.is_dir():
        return {}
    return {p.stem: read_json(p) for p in sorted(folder.glob("*.json"))}


def verdict_markdown(ctx: RunContext, claim_id: str, decision: Decision) -> str:
    """A short markdown block for the notebook's verdict cell."""
    claim = get_claim(claim_id)
    mode = " *(quick run: a test of the code, not a result)*" if ctx.quick else ""
    return (f"**{claim.id} — {decision.verdict}**{mode}\n\n"
            f"*Rule (fixed before the run):* {claim.rule}\n\n*Why:* {decision.reason}")
