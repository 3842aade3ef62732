"""The claims registry, version 5: every claim of ../shared/CLAIMS.md with its verdict rule.

Each rule is written here *before* the experiment that feeds it, names the measurements it
needs, and is never loosened after a run; its text is a template the run's settings are
rendered into when the claim is recorded (``Claim.render_rule``). What changed in each version
and why, claim by claim: docs/REGISTRY_CHANGELOG.md. The entries live in ``registry_gmd`` and
``registry_energymogen``; outcomes and verdicts in ``repro.claims.verdicts``; what a run
could see in ``repro.claims.power``. Version 1's frozen rules were retired in version 4: the
report shows the previous snapshot's verdict beside each new one (``claims.trust``).
"""

from __future__ import annotations

from typing import Any

from repro.claims.claim import REGISTRY_VERSION, Claim
from repro.claims.gating import Reading
from repro.claims.registry_energymogen import CLAIMS as _ENERGYMOGEN
from repro.claims.registry_energymogen import READINGS as _ENERGYMOGEN_READINGS
from repro.claims.registry_gmd import CLAIMS as _GMD
from repro.claims.registry_gmd import READINGS as _GMD_READINGS
from repro.core.stats import t_interval

__all__ = ["CLAIMS", "READINGS", "REGISTRY_VERSION", "Claim", "claims_for_notebook",
           "get_claim", "interval_summary"]

CLAIMS: dict[str, Claim] = {c.id: c for c in [*_GMD, *_ENERGYMOGEN]}

#: claim → part → what the part reads of its models (gates version 5, ``claims.gating``)
READINGS: dict[str, dict[str, Reading]] = {**_GMD_READINGS, **_ENERGYMOGEN_READINGS}


def get_claim(claim_id: str) -> Claim:
    """The registered claim, or a ValueError naming the unknown ID and the known ones."""
    try:
        return CLAIMS[claim_id]
    except KeyError:
        raise ValueError(f"unknown claim ID {claim_id!r}; known: {', '.join(CLAIMS)}") from None


def claims_for_notebook(notebook: str) -> list[Claim]:
    return [c for c in CLAIMS.values() if c.notebook == notebook]


def interval_summary(values: Any) -> Any:
    """Replace per-seed lists (also inside dicts) by mean and interval, for the report."""
    if isinstance(values, dict):
        return {k: interval_summary(v) for k, v in values.items()}
    if isinstance(values, list | tuple) and values and all(
            isinstance(v, int | float) for v in values) and len(values) > 1:
        return t_interval(values).as_dict()
    return values
