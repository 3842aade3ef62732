"""GMD-C4's descriptive readings outside the rule (notebook 03): how κ(P) of each seed's
Emphasis matrix relates to its foot skating, and every Emphasis arm outside the rule against
the rule's arms (``emphasis_study.Results``). Neither enters a verdict."""

from __future__ import annotations

from typing import Any

import numpy as np

from repro.gmd.emphasis_study import Results, Variant

__all__ = ["kappa_skating_relation", "outside_rule_summary"]


def kappa_skating_relation(results: Results) -> dict[str, dict[str, float | int | None]]:
    """Spearman's rank correlation between κ(P) and foot skating over the seeds of each
    Gaussian Emphasis value of the rule ({str(c): {"rho", "p", "n"}}; ρ and p None below
    three seeds or where either is constant). Descriptive: not part of the rule."""
    from scipy import stats

    out: dict[str, dict[str, float | int | None]] = {}
    for value, kappas in results.kappa_per_value().items():
        skating = results.per_value("emphasis", "foot_skating")[value]
        rho = p = None
        if len(kappas) >= 3 and np.ptp(kappas) > 0 and np.ptp(skating) > 0:
            test = stats.spearmanr(kappas, skating)
            rho, p = float(test.statistic), float(test.pvalue)
        out[value] = {"rho": rho, "p": p, "n": len(kappas)}
    return out


def outside_rule_summary(results: Results) -> dict[str, dict[str, Any]]:
    """Every Emphasis arm outside the rule ({label: ...}): per-seed foot skating and κ(P),
    and paired over seeds (95 % t-intervals, ``Interval.as_dict``) loss scaling k = c − the
    arm (the rule's direction) and the arm − the rule's Gaussian arm at the same c."""
    from repro.core.stats import paired_difference, t_interval

    summary = {}
    for variant in results.outside_rule:
        if variant.method != "emphasis":
            continue
        arm = results.imputed[variant.label]["foot_skating"]
        loss = results.imputed[Variant("loss_scaling", variant.value).label]["foot_skating"]
        gaussian = results.imputed[Variant("emphasis", variant.value).label]["foot_skating"]
        summary[variant.label] = {
            "value": variant.value, "kind": variant.kind, "precision": variant.precision,
            "foot_skating": list(arm), "condition_number": results.condition_numbers[
                variant.label],
            "loss_scaling_minus_arm": t_interval(paired_difference(loss, arm)).as_dict(),
            "arm_minus_gaussian": t_interval(paired_difference(arm, gaussian)).as_dict()}
    return summary
