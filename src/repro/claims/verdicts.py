"""Verdicts of registry version 6: five outcomes per part, five verdicts per claim.

A claim is decided from *parts*; each part is one or more per-seed paired differences
(``Comparison``), oriented so that a positive difference is the paper's direction, each with
the smallest effect of interest δ and the measurement's resolution r registered beside it.
Every outcome comes from the run's own seeds: no seed count registered elsewhere changes it.
Where δ is a stated fraction of an arm's mean, the per-seed "difference" is a log ratio of
the two arms (``log_ratios``) and δ the same boundary on the log scale (``log_margin``): a
relative effect that is steady across seeds while the arms' level is not has the spread of
the ratio, not of the level.

Per part (``decide_parts``):

- **below resolution**: every difference of a comparison lies within ±r (a measurement
  quantised by its test-set size, e.g. R@3 moved by one clip in 256): the test set cannot
  resolve the effect, so the part is neither supported nor contradicted.
- **supported**: the one-sided t-test of "difference > 0" (non-inferiority parts: "> −δ")
  rejects at family-wise α = 0.025 over the claim's parts (Holm), for every comparison of
  the part (an intersection–union test: its p-value is the largest).
- **contradicted**: the same test in the other direction (Holm over parts and comparisons).
  A significant result against the paper is evidence exactly as one for it is (v4: v3 turned
  it into "inconclusive" when the run had fewer seeds than a power plan asked for).
- **absent**: equivalence by two one-sided tests (TOST, Schuirmann 1987): the 90 % t-interval
  of the difference lies inside ±δ, for every comparison.
- **inconclusive**: none of these; the reason says why — a measurement not recorded, a part
  its scale does not run (``decide_effects``' ``not_run``: a registered cut), one seed,
  no spread to test with, or an interval that reaches beyond ±δ on both sides of zero, with
  the smallest effect this run could have seen (``power.minimum_detectable_effect`` at its n
  and its own spread) beside δ.

The spread of a comparison's differences is never taken below r/√6, the rounding error of a
difference of two values each rounded to a multiple of r (uniform on ±r/2, sd r/√12 each):
differences that tie to the last quantisation step have not shown that they do not vary, so
identical differences never give p = 0. A continuous measurement (r = 0) whose differences
are identical in every seed has no error estimate: inconclusive.

Per claim (``combine``): *reproduced* if every part is supported; *partially reproduced* if
at least one effect part is supported (a non-inferiority part — "not worse" — never makes a
claim partial on its own); *not reproduced* if every effect part is absent or contradicted
(a finding: the intersection–union test needs no correction); *inconclusive* otherwise,
naming each undecided part and why; *discrepancy in the paper* for exact checks of printed
formulas. A null control that fires (it guards false positives) makes the claim
inconclusive; a missed positive control (it guards false negatives) makes inconclusive only
the parts that were not significant (absent, inconclusive) — a supported or contradicted
part stands; a model that failed its fitness gate makes inconclusive the parts that read it
(``apply_controls``). A control's arms are the experiment's pairing (the same draws, δ
planted exactly): its rounding ties are zero and a difference identical in every seed is
decided by its sign (``decide_parts``' ``exact``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy import stats

from repro.claims.power import ALPHA, MOST_SEEDS, minimum_detectable_effect, seeds_to_see
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

EQUIVALENCE_ALPHA = 0.05  # each one-sided test of TOST: the 90 % interval

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
    measurement names it reads (a missing one makes the part inconclusive, never an error)."""

    name: str
    text: str
    needs: tuple[str, ...]
    compare: Callable[[Measured], list[Comparison]]
    smallest_effect_reason: str
    resolution: float = 0.0
    resolution_reason: str = "continuous measurement"
    kind: Kind = "effect"
    #: what a comparison's differences are: "difference" (in the measurement's units) or
    #: "log ratio" (``log_ratios``; δ and the resolution on the log scale)
    scale: str = "difference"


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


def spread_floor(resolution: float) -> float:
    """The least spread a comparison's differences are tested with: r/√6, the sd of the
    rounding error of a difference of two values each rounded to a multiple of r."""
    return resolution / np.sqrt(6.0)


def _spread(differences: Sequence[float], floor: float) -> float:
    array = np.asarray(differences, dtype=np.float64)
    return max(float(array.std(ddof=1)) if array.size > 1 else 0.0, floor)


def one_sided_p(differences: Sequence[float], null_value: float,
                alternative: Literal["greater", "less"], floor: float = 0.0, *,
                exact: bool = False) -> float:
    """p of the one-sided one-sample t-test of mean(differences) vs ``null_value``, the spread
    taken as at least ``floor`` (:func:`spread_floor`). Without two seeds nothing is tested:
    p = 1. Without any spread (identical differences of a continuous measurement) an
    experiment has no error estimate (p = 1); an ``exact`` comparison (a control built on
    paired draws, :func:`exact_differences`) has no error to estimate, and its sign decides it:
    p = 0 when every difference lies strictly on the alternative's side of ``null_value``."""
    array = np.asarray(differences, dtype=np.float64)
    spread = _spread(array, floor)
    if array.size < 2:
        return 1.0
    if spread == 0.0:
        side = array > null_value if alternative == "greater" else array < null_value
        return 0.0 if exact and bool(side.all()) else 1.0
    t = (float(array.mean()) - null_value) / (spread / np.sqrt(array.size))
    tail = stats.t.sf if alternative == "greater" else stats.t.cdf
    return float(tail(t, array.size - 1))


#: in a control built on paired draws, a difference within this fraction of δ is a tie: the
#: floating-point rounding of an exact plant (float32 features: ~1e-7 of the measured level,
#: itself at most δ/φ with every registered φ ≥ 0.035), not an effect
EXACT_TIE = 1e-3


def exact_differences(comparison: Comparison) -> Comparison:
    """A control's comparison with its rounding ties set to exactly zero (``EXACT_TIE``): the
    arms of a paired control are the same draws, so a difference that is zero up to rounding
    is zero, and an exact comparison is decided by its sign (:func:`one_sided_p`)."""
    tie = EXACT_TIE * abs(comparison.smallest_effect)
    return Comparison(comparison.label, [0.0 if abs(d) <= tie else float(d)
                                         for d in comparison.differences],
                      comparison.smallest_effect, comparison.resolution)


def equivalent(differences: Sequence[float], smallest_effect: float,
               floor: float = 0.0) -> bool:
    """TOST at 5 % per side: the 90 % t-interval (spread at least ``floor``) lies strictly
    inside ±δ."""
    array = np.asarray(differences, dtype=np.float64)
    spread = _spread(array, floor)
    if array.size < 2 or smallest_effect <= 0 or spread == 0.0:
        return False
    half = float(stats.t.ppf(1 - EQUIVALENCE_ALPHA, array.size - 1) * spread
                 / np.sqrt(array.size))
    mean = float(array.mean())
    return -smallest_effect < mean - half and mean + half < smallest_effect


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
                lower_is_better: bool, fraction: float, log_ratio: bool = False,
                step: float = 0.0) -> list[Comparison]:
    """"``claimed`` is the best option" as one comparison per other option, seed by seed
    (claimed better → positive), δ = ``fraction`` × |mean of the other option|. With
    ``log_ratio`` each comparison is the per-seed log ratio, better over worse
    (``log_ratios``, offset half a ``step`` for a counted measurement), and δ the same
    boundary on the log scale (``log_margin``: log(1 + φ) for higher-is-better, where the
    other option is the denominator; −log(1 − φ) for lower-is-better, where it is the
    numerator). An option identical to ``claimed`` in every seed (an exact tie) gives
    all-zero differences, which come out *below resolution*: neither better nor worse."""
    if claimed not in per_option:
        raise ValueError(f"option {claimed!r} not measured; have {sorted(per_option)}")
    sign = -1.0 if lower_is_better else 1.0
    mine = np.asarray(per_option[claimed], dtype=np.float64)
    comparisons = []
    for other, values in per_option.items():
        if other == claimed:
            continue
        theirs = np.asarray(values, dtype=np.float64)
        if not log_ratio:
            comparisons.append(Comparison(f"vs {other}", (sign * (mine - theirs)).tolist(),
                                          fraction * abs(float(theirs.mean()))))
            continue
        better, worse = (theirs, mine) if lower_is_better else (mine, theirs)
        comparisons.append(Comparison(
            f"vs {other}", log_ratios(better.tolist(), worse.tolist(), offset=step / 2,
                                      what=f"{claimed} vs {other}"),
            log_margin(fraction, of="numerator" if lower_is_better else "denominator"),
            log_resolution(better.tolist(), worse.tolist(), step)))
    return comparisons


def log_margin(fraction: float, *, of: Literal["numerator", "denominator"],
               factor: float = 1.0, kind: Kind = "effect") -> float:
    """δ on the log scale of a part registered as f·a − b > 0 with δ = φ × the mean of one
    arm (φ = ``fraction``, f = ``factor``), at the same boundary:

    - effect, φ of b: f·a − b ≥ φ·b ⇔ log(f·a/b) ≥ log(1 + φ);
    - effect, φ of a: f·a − b ≥ φ·a ⇔ log(f·a/b) ≥ log(f/(f − φ)) = −log(1 − φ/f);
    - non-inferiority (f·a − b > −δ), φ of b: log(f·a/b) > log(1 − φ), δ = −log(1 − φ);
    - non-inferiority, φ of a: log(f·a/b) > log(f/(f + φ)), δ = log(1 + φ/f)."""
    upper = {("effect", "numerator"): factor, ("non-inferiority", "denominator"): 1.0}.get(
        (kind, of), np.inf)
    if not 0.0 < fraction < upper:
        raise ValueError(f"a log margin of a {kind} part with δ a fraction of the {of} needs "
                         f"0 < φ < {upper:g}; got φ = {fraction}")
    if kind == "effect":
        return float(np.log1p(fraction) if of == "denominator"
                     else -np.log1p(-fraction / factor))
    return float(-np.log1p(-fraction) if of == "denominator" else np.log1p(fraction / factor))


def log_ratios(numerator: Sequence[Any], denominator: Sequence[Any], *, factor: float = 1.0,
               offset: float = 0.0, what: str = "a log-ratio part") -> list[float]:
    """log((f·a + o) / (b + o)) seed by seed (f = ``factor``, o = ``offset``: half an item of
    a counted measurement, so that a zero count keeps a ratio); seeds where either value is
    None (undefined) are left out. A ratio is a comparison of positive amounts: a value at or
    below zero raises a ValueError naming ``what``, the seed and the values (a ratio of a
    signed quantity is not a ratio)."""
    if len(numerator) != len(denominator):
        raise ValueError(f"{what}: paired values need the same seeds: {len(numerator)} vs "
                         f"{len(denominator)} values")
    out = []
    for index, (a, b) in enumerate(zip(numerator, denominator, strict=True)):
        if a is None or b is None:
            continue
        top, bottom = factor * float(a) + offset, float(b) + offset
        if not (top > 0 and bottom > 0 and float(a) >= 0 and float(b) >= 0):
            raise ValueError(f"{what}: seed {index} has {float(a):g} and {float(b):g}; a log "
                             "ratio compares positive amounts (a ratio of a signed quantity is "
                             "not a ratio)")
        out.append(float(np.log(top / bottom)))
    return out


def log_resolution(numerator: Sequence[Any], denominator: Sequence[Any], step: float
                   ) -> float:
    """The resolution of a log ratio of counted measurements: one item (``step``) at the
    lower arm's mean level m, log(1 + step/(m + step/2)) — the most one item moves the log
    ratio; 0 for a continuous measurement (``step`` 0)."""
    if step <= 0:
        return 0.0
    levels = [np.mean([float(v) for v in arm if v is not None] or [0.0])
              for arm in (numerator, denominator)]
    return float(np.log1p(step / (max(min(levels), 0.0) + step / 2)))


def _resolution(comparison: Comparison, part: Part) -> float:
    return part.resolution if comparison.resolution is None else comparison.resolution


def _below(comparison: Comparison, part: Part) -> bool:
    """Every difference within ± the resolution (effect parts only: a non-inferiority part
    tests "> −δ", which quantised values can pass)."""
    if part.kind != "effect":
        return False
    return bool(np.max(np.abs(comparison.differences))
                <= _resolution(comparison, part) * (1 + 1e-9))


def _floor(comparison: Comparison, part: Part) -> float:
    return spread_floor(_resolution(comparison, part))


def _part_numbers(part: Part, comparisons: list[Comparison], parts_tested: int
                  ) -> dict[str, Any]:
    """Per comparison: mean, 95 % interval, n, δ, the spread tested with, the resolution, the
    minimum detectable effect at this run's n and spread (80 % power at α/parts: Holm's
    first step) and the seeds that would see δ at that spread (``power.seeds_to_see``; None
    and ``spread_unknown`` with one seed or no spread: nothing to plan from)."""
    numbers: dict[str, Any] = {"resolution": part.resolution, "scale": part.scale}
    alpha = ALPHA / max(parts_tested, 1)
    for c in comparisons:
        interval = t_interval(c.differences)
        spread = _spread(c.differences, _floor(c, part))
        numbers[c.label or "difference"] = {
            "mean": interval.mean, "low": interval.low, "high": interval.high, "n": interval.n,
            "smallest_effect": c.smallest_effect, "spread": spread,
            "resolution": _resolution(c, part),
            "minimum_detectable_effect": minimum_detectable_effect(interval.n, spread,
                                                                   alpha=alpha),
            "seeds_to_see_delta": (None if interval.n < 2 or spread == 0.0 else
                                   seeds_to_see(c.smallest_effect, spread, alpha=alpha))}
        if interval.n < 2 or spread == 0.0:   # no spread measured: nothing to plan seeds from
            numbers[c.label or "difference"]["spread_unknown"] = True
    return numbers


def decide_parts(parts: Sequence[Part], measured: Measured, *, exact: bool = False
                 ) -> list[PartResult]:
    """Every part's outcome, with Holm over the claim's testable parts (module docstring).
    ``exact``: the measurements are a control's, its arms built on the same draws with δ
    planted exactly (paired like the experiment): rounding ties are zero
    (:func:`exact_differences`) and a comparison identical in every seed is decided by its
    sign, not left without an error estimate."""
    evaluated: list[tuple[Part, list[Comparison]] | PartResult] = []
    for part in parts:
        missing = [name for name in part.needs if name not in measured]
        if missing:
            evaluated.append(PartResult(part.name, INCONCLUSIVE,
                                        f"measurement {', '.join(missing)} not recorded"))
            continue
        try:
            comparisons = [exact_differences(c) if exact else c
                           for c in part.compare(measured) if c.differences]
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
        return one_sided_p(c.differences, null, alternative, _floor(c, part), exact=exact)

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
        numbers = _part_numbers(part, comparisons, len(testable))
        numbers["p_support"], numbers["p_contradict"] = support_p[index], contra_p[index]
        results.append(_outcome(part, comparisons, supported[index], contradicted[index],
                                numbers, exact=exact))
        index += 1
    return results


def _units(part: Part) -> str:
    return " in log ratio" if part.scale == "log ratio" else ""


def _could_see(comparisons: list[Comparison], numbers: Mapping[str, Any]) -> str:
    """"this run could see X (80 % power, n seeds, its own spread); δ is Y; N seeds would see
    δ at this spread" per comparison."""
    words = []
    for c in comparisons:
        row = numbers[c.label or "difference"]
        label = f"{c.label}: " if c.label else ""
        seeds = row.get("seeds_to_see_delta")
        needed = ("no spread measured to say how many seeds would see δ"
                  if row.get("spread_unknown") else
                  f"{seeds} seeds would see δ at this spread" if seeds is not None
                  else f"no seed count up to {MOST_SEEDS:,} would see δ at this spread")
        words.append(f"{label}this run could see {row['minimum_detectable_effect']:.3g} (80 % "
                     f"power, {row['n']} seeds, its own spread); δ is {c.smallest_effect:.3g}; "
                     f"{needed}")
    return "; ".join(words)


def _outcome(part: Part, comparisons: list[Comparison], supported: bool, contradicted: bool,
             numbers: dict[str, Any], *, exact: bool = False) -> PartResult:
    n = min(len(c.differences) for c in comparisons)
    ties = [c.label or "difference" for c in comparisons if _below(c, part)]
    if len(ties) == len(comparisons):
        return PartResult(part.name, BELOW_RESOLUTION, f"every difference within ±"
                          f"{_resolution(comparisons[0], part):.3g}{_units(part)} "
                          f"({part.resolution_reason})", numbers)
    if n < 2:
        return PartResult(part.name, INCONCLUSIVE, "one seed cannot decide a direction",
                          numbers)
    if not exact and all(_spread(c.differences, _floor(c, part)) == 0.0 for c in comparisons):
        return PartResult(part.name, INCONCLUSIVE, "the same difference in every seed of a "
                          "continuous measurement: no spread to test with (the seeds vary "
                          "nothing this measurement sees)", numbers)
    if supported and not ties:
        return PartResult(part.name, SUPPORTED, "every interval on the paper's side (Holm)"
                          if len(comparisons) > 1 else "on the paper's side (Holm over parts)",
                          numbers)
    if contradicted:
        return PartResult(part.name, CONTRADICTED, "significantly against the paper's "
                          "direction (Holm)", numbers)
    if ties:
        tied = [c for c in comparisons if _below(c, part)]
        return PartResult(part.name, BELOW_RESOLUTION, f"{', '.join(ties)}: every difference "
                          f"within ±{_resolution(tied[0], part):.3g}{_units(part)} (an exact "
                          f"tie at {part.resolution_reason})", numbers)
    if part.kind == "effect" and all(equivalent(c.differences, c.smallest_effect,
                                                _floor(c, part)) for c in comparisons):
        deltas = ", ".join(f"{c.smallest_effect:.3g}" for c in comparisons)
        return PartResult(part.name, ABSENT, f"no effect of the registered size: the 90 % "
                          f"interval lies inside ±δ = {deltas} (TOST)", numbers)
    return PartResult(part.name, INCONCLUSIVE, f"neither side after Holm (p = "
                      f"{numbers['p_support']:.2g} for, {numbers['p_contradict']:.2g} against) "
                      f"nor inside ±δ: {_could_see(comparisons, numbers)}", numbers)


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


def decide_effects(parts: Sequence[Part], measured: Measured,
                   not_run: Mapping[str, str] | None = None, *, exact: bool = False
                   ) -> Decision:
    """Decide a claim whose verdict rests on measured effects. ``not_run``: part name → why
    the run's scale does not run it (a cut registered before the run); such a part is
    inconclusive with that reason and stays out of Holm's family, like one not recorded.
    ``exact``: a control's measurements (:func:`decide_parts`)."""
    skipped = dict(not_run or {})
    unknown = sorted(set(skipped) - {p.name for p in parts})
    if unknown:
        raise ValueError(f"parts not run {unknown} are not the claim's parts "
                         f"{[p.name for p in parts]}")
    tested = {r.name: r for r in decide_parts([p for p in parts if p.name not in skipped],
                                              measured, exact=exact)}
    results = [tested[p.name] if p.name in tested
               else PartResult(p.name, INCONCLUSIVE, skipped[p.name]) for p in parts]
    if not tested and parts and len(set(skipped.values())) == 1:   # one cut, said once
        return Decision(combine(results, parts), next(iter(skipped.values())),
                        {r.name: r.outcome for r in results}, results)
    verdict = combine(results, parts)
    decision = Decision(verdict, "", {r.name: r.outcome for r in results}, results)
    decision.reason = decision.parts_in_words()
    return decision


def exact_decision(verdict: str, reason: str, checks: Mapping[str, bool]) -> Decision:
    """A decision from exact checks (no seeds): each check supported or contradicted."""
    results = [PartResult(name, SUPPORTED if ok else CONTRADICTED, "exact check")
               for name, ok in checks.items()]
    return Decision(verdict, reason, {r.name: r.outcome for r in results}, results)


def _missed_control(result: PartResult, control: str) -> PartResult:
    """A non-significant part under a missed positive control: inconclusive, saying why."""
    return PartResult(result.name, INCONCLUSIVE, f"the positive control missed ({control}): "
                      f"this measurement did not see an effect of the registered size, so a "
                      f"non-significant result says nothing (without it: {result.outcome} — "
                      f"{result.reason})", result.numbers)


def null_fired(null: Decision, *, exact: bool = True, not_run: Sequence[str] = ()) -> bool:
    """Whether a null control found an effect where none was planted. An exact null (paired
    draws of one model) fires when it comes out reproduced or partially; an A/A null (the
    reference arm against an independently trained copy, ``exact`` False) fires when any part
    that runs comes out supported or contradicted: between two copies of one arm no direction
    is real."""
    if exact:
        return null.verdict in (REPRODUCED, PARTIAL)
    return any(p.outcome in (SUPPORTED, CONTRADICTED) for p in null.parts
               if p.name not in set(not_run))


def apply_controls(decision: Decision, controls: Mapping[str, Decision | None],
                   quality_gates: Mapping[str, bool] | None = None,
                   gate_reads: Mapping[str, Sequence[str] | None] | None = None,
                   parts: Sequence[Part] | None = None, not_run: Sequence[str] = (),
                   *, exact_controls: bool = True) -> Decision:
    """The claim's decision after its controls and fitness gates.

    The two controls guard different errors. The null control (no effect planted) guards
    false positives: if it comes out reproduced or partially, the measurement finds effects
    where there are none, so no outcome of the claim can be trusted and the claim is
    inconclusive. The positive control (the registered δ planted) guards false negatives: if
    it is not reproduced, the measurement could not see δ, which says nothing against a part
    that *was* significant (supported or contradicted after Holm: its error rate is α
    whatever the power), but makes a non-significant one (absent, inconclusive) uninformative.
    So a missed positive control turns only the absent and inconclusive parts inconclusive,
    each with the reason, and the verdict is combined again from the parts. A failed gate
    makes inconclusive the parts that read its model (``gate_reads``: gate name → part names;
    absent or None: every part; []: a model no part rests on, shown but never deciding), and
    the verdict is combined again (``parts``: their kinds). A part in ``not_run`` (its
    scale does not run it) keeps its outcome and reason: no control or gate speaks to it, and
    a gate read only by such parts is reported, never decides. ``exact_controls`` False: the
    controls are A/A runs of independently trained models (:func:`null_fired`)."""
    kept = set(not_run)
    positive, null = controls.get("positive"), controls.get("null")
    if null is not None and null_fired(null, exact=exact_controls, not_run=not_run):
        problem = (f"the null control fired: the measurement finds an effect where none was "
                   f"planted (control: {null.verdict})")
        if positive is not None and positive.verdict != REPRODUCED:
            problem += f"; the positive control missed too (control: {positive.verdict})"
        return Decision(INCONCLUSIVE, f"{problem} — without controls: {decision.verdict}: "
                        f"{decision.reason}", dict(decision.checks), list(decision.parts))
    if positive is not None and positive.verdict != REPRODUCED:
        control = f"control: {positive.verdict}"
        if not decision.parts or decision.verdict == PAPER_DISCREPANCY:
            return Decision(INCONCLUSIVE, f"failed positive control ({control}) — without "
                            f"controls: {decision.verdict}: {decision.reason}",
                            dict(decision.checks), list(decision.parts))
        results = [_missed_control(p, control)
                   if p.outcome in (ABSENT, INCONCLUSIVE) and p.name not in kept else p
                   for p in decision.parts]
        controlled = Decision(combine(results, parts), "", {r.name: r.outcome for r in results},
                              results)
        missed = (f"failed positive control ({control}): the significant parts stand, the "
                  "others are inconclusive; ")
        controlled.reason = missed + controlled.parts_in_words()
        decision = controlled
    else:
        missed = ""
    # a gate whose model no part reads (``reads`` = []) is reported, never decides
    names = [p.name for p in decision.parts]

    def deciding(gate: str) -> bool:   # read by a part that runs
        reads = (gate_reads or {}).get(gate)
        return bool(set(names if reads is None else reads) - kept)

    failed = [name for name, ok in (quality_gates or {}).items()
              if not ok and (gate_reads or {}).get(name, None) != []
              and (not names or deciding(name))]
    if not failed:
        return decision
    resting: dict[str, list[str]] = {}
    for gate in failed:
        reads = (gate_reads or {}).get(gate)
        unknown = sorted(set(reads or ()) - set(names))
        if unknown:
            raise ValueError(f"gate {gate!r} reads parts {unknown}; the claim's parts are "
                             f"{names}")
        for name in (names if reads is None else reads):
            if name not in kept:
                resting.setdefault(name, []).append(gate)
    results = [PartResult(p.name, INCONCLUSIVE, f"rests on {', '.join(resting[p.name])}, which "
                          f"failed a gate this part reads of it (without it: {p.outcome})",
                          p.numbers)
               if p.name in resting else p for p in decision.parts]
    verdict = (INCONCLUSIVE if not names or decision.verdict == PAPER_DISCREPANCY
               else combine(results, parts))
    gated = Decision(verdict, "", {r.name: r.outcome for r in results}, results)
    gated.reason = (f"{missed}failed gate: {', '.join(failed)}; "
                    + (gated.parts_in_words() or f"without it: {decision.verdict}"))
    return gated
