"""A registered claim (registry version 4) and the helpers its entries are written with.

An entry reads as a table row: keyword arguments, the rule's text beside the parts that
implement it. Claims whose verdict rests on measured effects list ``parts`` (decided by
``repro.claims.verdicts.decide_effects``) and an ``example`` generator; exact checks of
printed formulas give ``exact_rule`` instead.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from repro.claims.verdicts import Comparison, Decision, Part, decide_effects

Measured = Mapping[str, Any]
Path = str | tuple[str, ...]
Example = Callable[[np.random.Generator, float, int], dict[str, Any]]

REGISTRY_VERSION = 4
SEEDS = "per-seed list"


@dataclass(frozen=True)
class Claim:
    """One claim: where it is, what it says, the rule, and the measurements the rule reads.

    ``measurements``: names every notebook records today (the ledger requires them);
    ``new_measurements``: names later versions read beyond v1's (recorded by the notebooks
    that run it; a part whose measurement is missing comes out inconclusive, "measurement X
    not recorded"); ``example(rng, scale, n)``: a measurement dict shaped like the notebook's
    with ``n`` seeds, every part's effect at ``scale`` × its smallest effect of interest (0:
    no effect, negative: the paper is wrong). How many seeds a run uses is the paper
    package's run settings' business, not the claim's (registry v4)."""

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

    def decide(self, measured: Measured) -> Decision:
        if self.exact_rule is not None:
            return self.exact_rule(measured)
        return decide_effects(self.parts, measured)

    @property
    def rests_on_effects(self) -> bool:
        return bool(self.parts)

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


def arm(rng: np.random.Generator, level: float, spread: float, n: int) -> list[float]:
    """n per-seed values around ``level`` (an example's arm)."""
    return (level + spread * rng.standard_normal(n)).tolist()


def quantise(values: Sequence[float], step: float) -> list[float]:
    """Values rounded to multiples of ``step`` (a measurement counted over a test set)."""
    return [round(v / step) * step for v in values]
