"""Blocks of README.md written from the results snapshot, between ``<!-- name:start … -->``
and ``<!-- name:end -->`` markers (the claims table, the budgets)."""

from __future__ import annotations

import os
from pathlib import Path

from repro.infra.storage import write_text


def replace_block(readme: str | os.PathLike, start: str, end: str, body: str) -> Path:
    """Rewrite what lies between the line starting with ``start`` and ``end`` (atomically);
    ValueError if the markers are missing."""
    readme = Path(readme)
    text = readme.read_text(encoding="utf-8")
    begin, stop = text.find(start), text.find(end)
    if begin < 0 or stop < begin:
        raise ValueError(f"{readme}: no markers ({start} ... {end})")
    body_start = text.index("\n", begin) + 1
    return write_text(readme, text[:body_start] + body.rstrip("\n") + "\n" + text[stop:])
