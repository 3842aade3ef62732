"""A tiny progress channel from the library to the runner that started the process.

The runner sets ``REPRO_PROGRESS_FILE`` (one file per notebook) for the kernel it starts; a
long loop in the library calls :func:`report` (``report("training", step, steps, loss=0.31)``)
and the runner polls the file to show the notebook's current stage. Without the variable (a
notebook opened by hand, a unit test) :func:`report` does nothing.

The file holds one JSON object, replaced atomically: ``{"stage", "step", "total", "values",
"time"}``. Writes are throttled to one every :data:`MIN_INTERVAL_S` seconds, except the first
and the last step of a stage, so that a tight loop pays almost nothing.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

__all__ = ["ENV_VARIABLE", "MIN_INTERVAL_S", "read", "report"]

ENV_VARIABLE = "REPRO_PROGRESS_FILE"
MIN_INTERVAL_S = 0.5

_last: dict[str, float] = {}


def _number(value: Any) -> Any:
    """Floats and ints as they are; tensors, numpy scalars and the rest by ``float``/``str``."""
    if isinstance(value, bool | int | float | str) or value is None:
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def report(stage: str, step: int | None = None, total: int | None = None,
           **values: Any) -> None:
    """Tell the runner (if any) that the process is at ``step`` of ``total`` in ``stage``.

    Args:
        stage: what runs now, e.g. "training GMD x0", "sampling", "evaluation".
        step: 1-based step within the stage (None: no count).
        total: the stage's number of steps (None: unknown).
        values: a few numbers to show beside it (e.g. ``loss=0.31``).
    """
    target = os.environ.get(ENV_VARIABLE)
    if not target:
        return
    now = time.monotonic()
    boundary = step is None or step <= 1 or (total is not None and step >= total)
    if not boundary and now - _last.get(stage, float("-inf")) < MIN_INTERVAL_S:
        return
    _last[stage] = now
    record = {"stage": str(stage), "step": step, "total": total,
              "values": {str(k): _number(v) for k, v in values.items()}, "time": time.time()}
    path = Path(target)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(record), encoding="utf-8")
        os.replace(tmp, path)
    except OSError:
        pass  # progress is a courtesy: it never stops the computation


def read(path: str | os.PathLike) -> dict[str, Any] | None:
    """The last record in ``path``, or None when there is none (yet) or it cannot be read."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
