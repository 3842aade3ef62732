"""Markdown from measured values: tables, intervals over seeds, and result prose.

Notebooks state results only through these, so a re-run from another seed rewrites every
number a reader sees (prose that states a result is rendered, never typed in).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from repro.core.stats import t_interval

__all__ = ["interval_text", "markdown_table", "render"]


def interval_text(values: Sequence[float], *, digits: int = 3,
                  decimals: int | None = None) -> str:
    """``mean ± half-width`` of the Student-t 95 % interval over seeds (one value: the value).

    ``digits`` significant digits for the mean (2 for the half-width), or ``decimals`` fixed
    decimals for both.
    """
    iv = t_interval(values)
    half = iv.high - iv.mean
    if decimals is not None:
        mean, width = f"{iv.mean:.{decimals}f}", f"{half:.{decimals}f}"
    else:
        mean, width = f"{iv.mean:.{digits}g}", f"{half:.2g}"
    return f"{mean} ± {width}" if iv.n > 1 else mean


def _cell(value: object) -> str:
    return f"{value:.3f}" if isinstance(value, float) else str(value)


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub-markdown table; floats with 3 decimals, anything else as ``str``."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def render(template: str, /, **values: Any) -> str:
    """``template.format(**values)``, refusing a template that names a value not given.

    The helper behind every sentence that states a result: the numbers come from ``values``
    (measured in this run), never from the text.
    """
    try:
        return template.format(**values)
    except KeyError as missing:
        raise ValueError(f"result text names {missing} but no such value was measured; "
                         f"have {sorted(values)}") from None
