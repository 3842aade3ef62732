"""Verdicts of registry version 2: five outcomes per part, five verdicts per claim.

A claim is decided from *parts*; each part is one or more per-seed paired differences
(``Comparison``), oriented so that a positive difference is the paper's direction, each with
the smallest effect of interest δ and the measurement's resolution r registered beside it.

Per part (``decide_parts``):

- **below resolution**: every difference of a comparison lies within ±r (a measurement
  quantised by its test-set size, e.g. R@3 moved by one clip in 256): the test set cannot
  resolve the effect, so the part is neither supported nor contradicted.
- **supported**: the one-sided t-test of "difference > 0" (non-inferiority parts: "> −δ")
  rejects at family-wise α = 0.025 over the claim's parts (Holm), for every comparison of
  the part (an intersection–union test: its p-value is the largest). For one part this is
  v1's "the 95 % t-interval excludes zero".
- **contradicted**: the same test in the other direction (Holm over parts and comparisons).
- **absent**: equivalence by two one-sided tests (TOST, Schuirmann 1987): the 90 % t-interval
  of the difference lies inside ±δ, for every comparison.
- **inconclusive**: none of these; the reason says why: a measurement not recorded, one seed,
  too few seeds for the registered power (such a part can only come out supported or
  inconclusive), or an interval that reaches beyond ±δ on both sides of zero.

Per claim (``combine``): *reproduced* if every part is supported; *partially reproduced* if
at least one effect part is supported (a non-inferiority part — "not worse" — never makes a
claim partial on its own); *not reproduced* if every effect part is absent or contradicted
(a finding: the intersection–union test needs no correction); *inconclusive* otherwise,
naming each undecided part and why; *discrepancy in the paper* for exact checks of printed
formulas. A failed positive control, a null control that fires, or a model that failed its
quality gate makes any verdict inconclusive (``apply_controls``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy import stats

from repro.core.stats import t_interval

SUPPORTED = "supported"
CONTRADICTED = "contradicted"
ABSENT = "absent"
INCONCLUSIVE = "inconclusive"
BELOW_RESOLUTION = "below resolution"
OUTCOMES = (SUPPORTED, CONTRADICTED, ABSENT, INCONCLUSIVE, BELOW_RESOLUTION)

REPRODUCED = "reproduced"
PARTIAL = "partially reproduced"
NOT_REPRODUCED = "not reproduced"
PAPER_DISCREPANCY = "discrepancy in the paper"
VERDICTS = (REPRODUCED, PARTIAL, NOT_REPRODUCED, INCONCLUSIVE, PAPER_DISCREPANCY)

ALPHA = 0.025            # one-sided, family-wise over a claim's parts (Holm)
EQUIVALENCE_ALPHA = 0.05  # each one-sided test of TOST: the 90 % interval
POWER = 0.8

Measured = Mapping[str, Any]
Kind = Literal["effect", "non-inferiority"]


@dataclass(frozen=True)
class Comparison:
    """Per-seed paired differences (positive = the paper's direction) and δ in their units."""

    label: str
    differences: list[float]
    smallest_effect: float
    resolution: float | None = None  # None: the part's


@dataclass(frozen=True)
class Part:
    """A registered part of a claim: what it tests, how, and at what size.

    ``compare`` turns the notebook's measurements into comparisons; ``needs`` are the
    measurement names it reads (a missing one makes the part inconclusive, never an error);
    ``seeds`` is the number the power calculation asks for (``repro.claims.power``)."""

    name: str
    text: str
    needs: tuple[str, ...]
    compare: Callable[[Measured], list[Comparison]]
    smallest_effect_reason: str
    resolution: float = 0.0
    resolution_reason: str = "continuous measurement"
    seeds: int = 2
    kind: Kind = "effect"


@dataclass(frozen=True)
class PartResult:
    """One part's outcome, the reason in words and the numbers behind it."""

    name: str
    outcome: str
    reason: str
    numbers: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "outcome": self.outcome, "reason": self.reason,
                "numbers": self.numbers}


@dataclass
class Decision:
    """A verdict with its reason, each part's outcome (``checks``: name → outcome) and the
    parts in full."""

    verdict: str
    reason: str
    checks: dict[str, object] = field(default_factory=dict)
    parts: list[PartResult] = field(default_factory=list)
    v1_verdict: str | None = None  # set by the ledger: the frozen version 1 rule's verdict

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {self.verdict!r}; expected one of {VERDICTS}")

    def parts_in_words(self) -> str:
        """Each part's outcome in words ("name: outcome (reason)"), for every summary."""
        return parts_in_words([p.as_dict() for p in self.parts])


def parts_in_words(parts: Sequence[Mapping[str, Any]], *, reasons: bool = True) -> str:
    """Parts (as stored in a sidecar) in words: "name: outcome (reason); ..."."""
    if reasons:
        return "; ".join(f"{p['name']}: {p['outcome']} ({p['reason']})" for p in parts)
    return "; ".join(f"{p['name']}: {p['outcome']}" for p in parts)


def one_sided_p(differences: Sequence[float], null_value: float,
                alternative: Literal["greater", "less"]) -> float:
    """p of the one-sided one-sample t-test of mean(differences) vs ``null_value`` (scipy).
    Identical differences have no spread: p = 0 on the far side of the null value, else 1."""
    array = np.asarray(differences, dtype=np.float64)
    if array.size < 2:
        return 1.0
    if np.ptp(array) == 0.0:
        beyond = array[0] > null_value if alternative == "greater" else array[0] < null_value
        return 0.0 if beyond else 1.0
    return float(stats.ttest_1samp(array, null_value, alternative=alternative).pvalue)


def equivalent(differences: Sequence[float], smallest_effect: float) -> bool:
    """TOST at 5 % per side: the 90 % t-interval lies strictly inside ±δ."""
    if len(differences) < 2 or smallest_effect <= 0:
        return False
    interval = t_interval(differences, confidence=1 - 2 * EQUIVALENCE_ALPHA)
    return -smallest_effect < interval.low and interval.high < smallest_effect


def holm(p_values: Sequence[float], alpha: float = ALPHA) -> list[bool]:
    """Holm's step-down rejections (family-wise error ≤ alpha for any dependence)."""
    order = np.argsort(np.asarray(p_values, dtype=np.float64), kind="stable")
    reject = [False] * len(p_values)
    for rank, index in enumerate(order):
        if p_values[index] > alpha / (len(p_values) - rank):
            break
        reject[index] = True
    return reject


def best_option(claimed: str, per_option: Mapping[str, Sequence[float]], *,
                lower_is_better: bool, fraction: float) -> list[Comparison]:
    """"``claimed`` is the best option" as one comparison per other option, seed by seed
    (claimed better → positive), δ = ``fraction`` × |mean of the other option|. An option
    identical to ``claimed`` in every seed (an exact tie) gives all-zero differences, which
    come out *below resolution*: neither better nor worse."""
    if claimed not in per_option:
        raise ValueError(f"option {claimed!r} not measured; have {sorted(per_option)}")
    sign = -1.0 if lower_is_better else 1.0
    mine = np.asarray(per_option[claimed], dtype=np.float64)
    comparisons = []
    for other, values in per_option.items():
        if other == claimed:
            continue
        theirs = np.asarray(values, dtype=np.float64)
        comparisons.append(Comparison(f"vs {other}", (sign * (mine - theirs)).tolist(),
                                      fraction * abs(float(theirs.mean()))))
    return comparisons


def _below(comparison: Comparison, part: Part) -> bool:
    """Every difference within ± the resolution (effect parts only: a non-inferiority part
    tests "> −δ", which quantised values can pass)."""
    if part.kind != "effect":
        return False
    resolution = part.resolution if comparison.resolution is None else comparison.resolution
    return bool(np.max(np.abs(comparison.differences)) <= resolution * (1 + 1e-9))


def _part_numbers(part: Part, comparisons: list[Comparison]) -> dict[str, Any]:
    numbers: dict[str, Any] = {"seeds_required": part.seeds, "resolution": part.resolution}
    for c in comparisons:
        interval = t_interval(c.differences)
        numbers[c.label or "difference"] = {"mean": interval.mean, "low": interval.low,
                                            "high": interval.high, "n": interval.n,
                                            "smallest_effect": c.smallest_effect}
    return numbers


def decide_parts(parts: Sequence[Part], measured: Measured) -> list[PartResult]:
    """Every part's outcome, with Holm over the claim's testable parts (module docstring)."""
    evaluated: list[tuple[Part, list[Comparison]] | PartResult] = []
    for part in parts:
        missing = [name for name in part.needs if name not in measured]
        if missing:
            evaluated.append(PartResult(part.name, INCONCLUSIVE,
                                        f"measurement {', '.join(missing)} not recorded"))
            continue
        try:
            comparisons = [c for c in part.compare(measured) if c.differences]
        except KeyError as error:  # a nested row (e.g. one λ) the notebook did not record
            evaluated.append(PartResult(part.name, INCONCLUSIVE,
                                        f"measurement {error.args[0]} not recorded"))
            continue
        if not comparisons:
            evaluated.append(PartResult(part.name, INCONCLUSIVE, "no seed measured"))
            continue
        evaluated.append((part, comparisons))
    testable = [e for e in evaluated if not isinstance(e, PartResult)]

    def p_of(part: Part, c: Comparison, alternative: Literal["greater", "less"]) -> float:
        null = -c.smallest_effect if part.kind == "non-inferiority" else 0.0
        return one_sided_p(c.differences, null, alternative)

    # a part with a comparison below resolution cannot be supported: it enters Holm's family
    # with p = 1, so it cannot loosen the other parts' thresholds; the comparisons it does
    # resolve can still contradict it (Bonferroni over them)
    support_p, contra_p = [], []
    for part, comparisons in testable:
        resolved = [c for c in comparisons if not _below(c, part)]
        support_p.append(max(p_of(part, c, "greater") for c in comparisons)
                         if len(resolved) == len(comparisons) else 1.0)
        contra_p.append(min(1.0, len(resolved) * min(p_of(part, c, "less") for c in resolved))
                        if resolved else 1.0)
    supported, contradicted = holm(support_p), holm(contra_p)
    results, index = [], 0
    for entry in evaluated:
        if isinstance(entry, PartResult):
            results.append(entry)
            continue
        part, comparisons = entry
        results.append(_outcome(part, comparisons, supported[index], contradicted[index],
                                support_p[index]))
        index += 1
    return results


def _outcome(part: Part, comparisons: list[Comparison], supported: bool, contradicted: bool,
             p_support: float) -> PartResult:
    numbers = _part_numbers(part, comparisons)
    numbers["p_support"] = p_support
    n = min(len(c.differences) for c in comparisons)
    underpowered = n < part.seeds
    power_note = f"{n} seeds of the {part.seeds} the power calculation asks for"
    ties = [c.label or "difference" for c in comparisons if _below(c, part)]
    if len(ties) == len(comparisons):
        return PartResult(part.name, BELOW_RESOLUTION, f"every difference within ±"
                          f"{part.resolution:.3g} ({part.resolution_reason})", numbers)
    if n < 2:
        return PartResult(part.name, INCONCLUSIVE, "one seed cannot decide a direction",
                          numbers)
    if supported and not ties:
        return PartResult(part.name, SUPPORTED, "every interval on the paper's side (Holm)"
                          if len(comparisons) > 1 else "on the paper's side (Holm over parts)",
                          numbers)
    if contradicted:
        if underpowered:
            return PartResult(part.name, INCONCLUSIVE, f"points the other way, but power: "
                              f"{power_note}", numbers)
        return PartResult(part.name, CONTRADICTED, "significantly against the paper's "
                          "direction (Holm)", numbers)
    if ties:
        return PartResult(part.name, BELOW_RESOLUTION, f"{', '.join(ties)}: every difference "
                          f"within ±{part.resolution:.3g} (an exact tie at "
                          f"{part.resolution_reason})", numbers)
    if underpowered:
        return PartResult(part.name, INCONCLUSIVE, f"power: {power_note}", numbers)
    if part.kind == "effect" and all(equivalent(c.differences, c.smallest_effect)
                                     for c in comparisons):
        deltas = ", ".join(f"{c.smallest_effect:.3g}" for c in comparisons)
        return PartResult(part.name, ABSENT, f"no effect of the registered size: the 90 % "
                          f"interval lies inside ±δ = {deltas} (TOST)", numbers)
    return PartResult(part.name, INCONCLUSIVE, f"neither on the paper's side after Holm (p = "
                      f"{p_support:.2g}) nor inside ± the smallest effect of interest", numbers)


def combine(results: Sequence[PartResult], parts: Sequence[Part] | None = None) -> str:
    """The claim's verdict from its parts' outcomes (module docstring)."""
    kinds = {p.name: p.kind for p in parts or ()}
    effect = [r for r in results if kinds.get(r.name, "effect") == "effect"] or list(results)
    if all(r.outcome == SUPPORTED for r in results):
        return REPRODUCED
    if any(r.outcome == SUPPORTED for r in effect):
        return PARTIAL
    if all(r.outcome in (ABSENT, CONTRADICTED) for r in effect):
        return NOT_REPRODUCED
    return INCONCLUSIVE


def decide_effects(parts: Sequence[Part], measured: Measured) -> Decision:
    """Decide a claim whose verdict rests on measured effects."""
    results = decide_parts(parts, measured)
    verdict = combine(results, parts)
    decision = Decision(verdict, "", {r.name: r.outcome for r in results}, results)
    decision.reason = decision.parts_in_words()
    return decision


def exact_decision(verdict: str, reason: str, checks: Mapping[str, bool]) -> Decision:
    """A decision from exact checks (no seeds): each check supported or contradicted."""
    results = [PartResult(name, SUPPORTED if ok else CONTRADICTED, "exact check")
               for name, ok in checks.items()]
    return Decision(verdict, reason, {r.name: r.outcome for r in results}, results)


def apply_controls(decision: Decision, controls: Mapping[str, Decision | None],
                   quality_gates: Mapping[str, bool] | None = None) -> Decision:
    """The claim's decision after its controls and quality gates: a positive control (the
    registered effect planted) that is not reproduced, a null control (no effect) that comes
    out reproduced or partially, or a failed quality gate makes it inconclusive."""
    problems = []
    positive, null = controls.get("positive"), controls.get("null")
    if positive is not None and positive.verdict != REPRODUCED:
        problems.append(f"failed positive control: the measurement cannot see an effect of "
                        f"the registered size (control: {positive.verdict})")
    if null is not None and null.verdict in (REPRODUCED, PARTIAL):
        problems.append(f"the null control fired: the measurement finds an effect where none "
                        f"was planted (control: {null.verdict})")
    problems += [f"failed quality gate: {name}" for name, ok in (quality_gates or {}).items()
                 if not ok]
    if not problems:
        return decision
    return Decision(INCONCLUSIVE, "; ".join(problems) + f" — without controls: "
                    f"{decision.verdict}: {decision.reason}", dict(decision.checks),
                    list(decision.parts))
