"""A registered claim (registry version 5) and the helpers its entries are written with.

An entry reads as a table row: keyword arguments, the rule's text beside the parts that
implement it. Claims whose verdict rests on measured effects list ``parts`` (decided by
``repro.claims.verdicts.decide_effects``) and an ``example`` generator; exact checks of
printed formulas give ``exact_rule`` instead.

The rule's text is a template (``str.format`` fields such as ``{T}``, ``{stop_step}``,
``{seeds}``): what a run used — its diffusion steps, stop step, guidance strength, seeds,
items — is rendered into it from the settings the run's experiment returned
(``ClaimResult.settings``), never typed, so the recorded rule says what the run did.

A part tests either a per-seed difference (``difference_part``) or, where δ is a stated
fraction of an arm's mean, a per-seed log ratio (``ratio_part``): "10 % of the arm" is a
ratio, and a ratio steady across seeds whose level is not is seen through its log.
"""

from __future__ import annotations

import string
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from repro.claims.verdicts import (
    Comparison,
    Decision,
    Kind,
    Part,
    decide_effects,
    log_margin,
    log_ratios,
    log_resolution,
)

Measured = Mapping[str, Any]
Path = str | tuple[str, ...]
Example = Callable[[np.random.Generator, float, int], dict[str, Any]]

REGISTRY_VERSION = 12
SEEDS = "per-seed list"


@dataclass(frozen=True)
class Claim:
    """One claim: where it is, what it says, the rule, and the measurements the rule reads.

    ``measurements``: names every notebook records today (the ledger requires them);
    ``new_measurements``: names later versions read beyond v1's (recorded by the notebooks
    that run it; a part whose measurement is missing comes out inconclusive, "measurement X
    not recorded"); ``example(rng, scale, n)``: a measurement dict shaped like the notebook's
    with ``n`` seeds, every part's effect at ``scale`` × its smallest effect of interest (0:
    no effect, negative: the paper is wrong; a log-ratio part's δ is on the log scale). How
    many seeds a run uses is the paper package's run settings' business, not the claim's
    (registry v4). ``rule`` is a template rendered by :meth:`render_rule` from the run's
    settings."""

    id: str
    paper: str
    section: str
    statement: str
    paper_value: str
    notebook: str
    rule: str
    measurements: dict[str, str]
    parts: tuple[Part, ...] = ()
    exact_rule: Callable[[Measured], Decision] | None = None
    new_measurements: dict[str, str] = field(default_factory=dict)
    example: Example | None = None

    def decide(self, measured: Measured, not_run: Mapping[str, str] | None = None, *,
               control: bool = False) -> Decision:
        """The claim's decision from ``measured``; ``not_run``: the parts its run's scale does
        not run, each with why; ``control``: ``measured`` is a control's, built on paired
        draws with δ planted exactly (``verdicts.decide_effects``' ``exact``)."""
        if self.exact_rule is not None:
            return self.exact_rule(measured)
        return decide_effects(self.parts, measured, not_run, exact=control)

    def required_measurements(self, not_run: Sequence[str] = ()) -> set[str]:
        """The measurements a run must record: every registered one but those that only
        parts in ``not_run`` read; none when no part runs."""
        skipped = set(not_run)
        if not skipped:
            return set(self.measurements)
        if skipped >= {p.name for p in self.parts}:
            return set()
        read = {name for p in self.parts if p.name not in skipped for name in p.needs}
        only_skipped = {name for p in self.parts if p.name in skipped
                        for name in p.needs} - read
        return set(self.measurements) - only_skipped

    @property
    def rests_on_effects(self) -> bool:
        return bool(self.parts)

    @property
    def rule_fields(self) -> tuple[str, ...]:
        """The settings the rule's template names (``{T}``, ``{seeds}``, ...), in order."""
        names = [field_name for _, field_name, _, _ in string.Formatter().parse(self.rule)
                 if field_name is not None]
        return tuple(dict.fromkeys(names))

    def render_rule(self, settings: Mapping[str, Any]) -> str:
        """The rule's text with the run's ``settings`` in it (:func:`setting_text` for each);
        a :class:`MissingRuleSetting` naming the claim and every field it lacks."""
        missing = [name for name in self.rule_fields if name not in settings]
        if missing:
            raise MissingRuleSetting(
                f"{self.id}: the rule quotes the run's {', '.join(missing)}, which the "
                f"experiment's result did not give (ClaimResult.settings has "
                f"{sorted(settings) or 'nothing'})")
        return self.rule.format(**{name: setting_text(settings[name])
                                   for name in self.rule_fields})

    def rule_as_registered(self) -> str:
        """The template with its fields shown as ⟨name⟩ (the rule before a run fills it)."""
        return self.rule.format(**{name: f"⟨{name}⟩" for name in self.rule_fields})

    def null_example(self, rng: np.random.Generator, n: int = 5) -> dict[str, Any]:
        """Measurements of ``n`` seeds with no effect in any part."""
        return self.example_at(rng, 0.0, n)

    def planted_example(self, rng: np.random.Generator, n: int = 5) -> dict[str, Any]:
        """Measurements of ``n`` seeds with every part's registered effect planted."""
        return self.example_at(rng, 1.0, n)

    def example_at(self, rng: np.random.Generator, scale: float, n: int) -> dict[str, Any]:
        """Measurements of ``n`` seeds, every part's effect at ``scale`` × its δ."""
        if self.example is None:
            raise ValueError(f"{self.id} rests on exact checks, not on measured effects: it "
                             "has no examples")
        return self.example(rng, scale, n)


class MissingRuleSetting(ValueError):
    """A rule's template names a setting the run's result did not give."""


def setting_text(setting: Any) -> str:
    """A run setting as a rule quotes it: a number as written (1000, 2.5, 6), a sequence as
    "{100, 150, 200}", anything else as its text."""
    if isinstance(setting, bool):
        return str(setting)
    if isinstance(setting, float) and setting.is_integer():
        return str(int(setting))
    if isinstance(setting, float):
        return f"{setting:g}"
    if isinstance(setting, list | tuple | set | frozenset):
        return "{" + ", ".join(setting_text(s) for s in setting) + "}"
    return str(setting)


def value(measured: Measured, path: Path) -> Any:
    """``measured[path]``, or ``measured[a][b]`` for a path ``(a, b)``; KeyError naming the
    path down to the missing key (``a[b]``: what a part reports as not recorded)."""
    if isinstance(path, str):
        return measured[path]
    out: Any = measured
    for depth, key in enumerate(path):
        try:
            out = out[key]
        except KeyError:
            raise KeyError(path[0] + "".join(f"[{k}]" for k in path[1:depth + 1])) from None
    return out


def mean_of(measured: Measured, path: Path) -> float:
    values = [v for v in np.atleast_1d(value(measured, path)) if v is not None]
    return float(np.mean(np.asarray(values, dtype=np.float64)))


def paired(a: Sequence[Any], b: Sequence[Any]) -> list[float]:
    """a − b seed by seed; seeds where either is None (an undefined value) are left out."""
    if len(a) != len(b):
        raise ValueError(f"paired values need the same seeds: {len(a)} vs {len(b)} values")
    return [float(x) - float(y) for x, y in zip(a, b, strict=True)
            if x is not None and y is not None]


def difference_part(*, name: str, text: str, minuend: Path, subtrahend: Path,
                    smallest_effect: float, relative_to: Path | None, reason: str,
                    resolution: float = 0.0,
                    resolution_reason: str = "continuous measurement",
                    kind: str = "effect", minuend_factor: float = 1.0) -> Part:
    """A part testing ``minuend_factor``·m[minuend] − m[subtrahend] > 0 over seeds, with
    δ = ``smallest_effect`` × |mean(m[relative_to])| (or δ = ``smallest_effect`` when
    ``relative_to`` is None)."""

    def compare(m: Measured) -> list[Comparison]:
        a = [None if v is None else minuend_factor * float(v) for v in value(m, minuend)]
        delta = smallest_effect * (abs(mean_of(m, relative_to)) if relative_to else 1.0)
        return [Comparison("", paired(a, value(m, subtrahend)), delta)]

    needs = tuple(sorted({p if isinstance(p, str) else p[0] for p in (minuend, subtrahend)}))
    return Part(name=name, text=text, needs=needs, compare=compare,
                smallest_effect_reason=reason, resolution=resolution,
                resolution_reason=resolution_reason, kind=kind)  # type: ignore[arg-type]


def ratio_part(*, name: str, text: str, numerator: Path, denominator: Path, fraction: float,
               of: Literal["numerator", "denominator"], reason: str,
               numerator_factor: float = 1.0, step: float = 0.0,
               step_reason: str = "continuous measurement", kind: Kind = "effect") -> Part:
    """A part testing the per-seed log ratio log(f·m[numerator] / m[denominator]) > 0
    (non-inferiority: > −δ), f = ``numerator_factor``, where the registered δ is
    ``fraction`` of the mean of one arm (``of``). The log δ is the registered one at the
    boundary (``verdicts.log_margin``): f·a − b ≥ φ·b ⇔ log(f·a/b) ≥ log(1 + φ), and
    f·a − b ≥ φ·a ⇔ log(f·a/b) ≥ −log(1 − φ/f). ``step``: one item of a counted
    measurement (0: continuous); both compared quantities are then offset by half an item
    (a zero count stays a ratio) and the resolution is one item at the lower arm's level
    (``verdicts.log_resolution``). Values that are not positive raise a ValueError: a ratio
    of a signed quantity is not a ratio."""
    delta = log_margin(fraction, of=of, factor=numerator_factor, kind=kind)
    factor = f"{numerator_factor:g}·" if numerator_factor != 1.0 else ""
    label = f"{name}: log({factor}{_path_text(numerator)} / {_path_text(denominator)})"

    def compare(m: Measured) -> list[Comparison]:
        a, b = value(m, numerator), value(m, denominator)
        ratios = log_ratios(a, b, factor=numerator_factor, offset=step / 2, what=label)
        return [Comparison("", ratios, delta, log_resolution(a, b, step))]

    needs = tuple(sorted({p if isinstance(p, str) else p[0] for p in (numerator, denominator)}))
    return Part(name=name, text=text, needs=needs, compare=compare,
                smallest_effect_reason=f"{reason}; on the log scale δ = {delta:.4g}",
                resolution=step, resolution_reason=step_reason, kind=kind, scale="log ratio")


def _path_text(path: Path) -> str:
    return path if isinstance(path, str) else "[".join(path) + "]" * (len(path) - 1)


def arm(rng: np.random.Generator, level: float, spread: float, n: int) -> list[float]:
    """n per-seed values around ``level`` (an example's arm)."""
    return (level + spread * rng.standard_normal(n)).tolist()


def quantise(values: Sequence[float], step: float) -> list[float]:
    """Values rounded to multiples of ``step`` (a measurement counted over a test set)."""
    return [round(v / step) * step for v in values]
