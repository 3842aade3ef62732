"""``infra.context.RunSettings``: every notebook's settings come from its run, one way."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Self

import pytest

from repro.infra.context import RunSettings


@dataclass(frozen=True)
class _Table(RunSettings):
    scale: str
    steps: int

    @classmethod
    def for_scale(cls, scale: str, **overrides: Any) -> Self:
        return replace(cls(scale=scale, steps={"quick": 2, "standard": 900}[scale]), **overrides)


@dataclass(frozen=True)
class _Run:
    scale: str


def test_for_run_reads_the_runs_scale_and_keeps_the_overrides() -> None:
    assert _Table.for_run(_Run("standard")) == _Table("standard", 900)   # type: ignore[arg-type]
    assert _Table.for_run(_Run("quick"), steps=7) == _Table("quick", 7)  # type: ignore[arg-type]


def test_a_class_without_a_table_says_so() -> None:
    with pytest.raises(NotImplementedError, match="defines no settings table"):
        RunSettings.for_run(_Run("quick"))  # type: ignore[arg-type]
