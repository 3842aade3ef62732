"""A tiny progress channel from the library to the runner that started the process.

The runner sets ``REPRO_PROGRESS_FILE`` (one file per notebook) for the kernel it starts; a
long loop in the library calls :func:`report` (``report("training", step, steps, loss=0.31)``)
and the runner polls the file to show the notebook's current stage. Without the variable (a
notebook opened by hand, a unit test) :func:`report` does nothing.

A warning the person running should see (a corrupt cached model moved aside and retrained)
goes through :func:`notice`: one line appended to ``<progress file>.notices`` beside it, which
the runner prints and records in the report's provenance (:func:`notices` reads them).

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

__all__ = ["ENV_VARIABLE", "MIN_INTERVAL_S", "notice", "notices", "read", "report"]

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


def _notices_file(progress_file: str | os.PathLike) -> Path:
    return Path(progress_file).with_suffix(".notices")


def notice(message: str) -> None:
    """Tell the runner (if any) a warning that must reach the terminal and the report; one
    line per call, appended. Without a runner (no ``REPRO_PROGRESS_FILE``) it does nothing:
    the caller's ``warnings.warn`` is what a person working by hand sees."""
    target = os.environ.get(ENV_VARIABLE)
    if not target:
        return
    try:
        with open(_notices_file(target), "a", encoding="utf-8") as handle:
            handle.write(" ".join(str(message).split()) + "\n")
    except OSError:
        pass  # the warning still reaches the notebook's stderr


def notices(progress_file: str | os.PathLike) -> list[str]:
    """The warnings sent with :func:`notice` by the process reporting to ``progress_file``."""
    try:
        text = _notices_file(progress_file).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    return [line for line in text.splitlines() if line.strip()]
