"""What a person sees while ``reproduce`` runs.

Each running notebook reports its code cell (``<name>.cell.json``, written by the worker) and
the library's current stage (``<name>.stage.json``, ``infra.progress.report``). In a terminal
a block of lines is redrawn every second: one per running notebook (elapsed time, cell i of N,
stage with its step of steps and values such as the loss) and an overall estimate from the
slowest known times. Without a terminal (CI, a log file) one status line per running notebook
is printed every ``interval_s`` seconds.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from repro.infra import progress


def _duration(seconds: float) -> str:
    seconds = int(max(seconds, 0))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


def _values_text(values: dict) -> str:
    parts = []
    for key, value in values.items():
        parts.append(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}")
    return " ".join(parts)


def notebook_status(name: str, elapsed_s: float, progress_dir: Path) -> str:
    """``name  2m13s  cell 7/18  training x0 412/1000 loss=0.0312`` from the progress files."""
    parts = [name, _duration(elapsed_s)]
    cell = progress.read(progress_dir / f"{name}.cell.json")
    if cell:
        parts.append(f"cell {cell['cell']}/{cell['cells']}")
    stage = progress.read(progress_dir / f"{name}.stage.json")
    if stage and (not cell or stage.get("time", 0) >= cell.get("time", 0) - 1):
        text = str(stage.get("stage", ""))
        if stage.get("step") is not None:
            text += f" {stage['step']}" + (f"/{stage['total']}" if stage.get("total") else "")
        if stage.get("values"):
            text += " " + _values_text(stage["values"])
        parts.append(text)
    elif cell and cell.get("source"):
        parts.append(repr(cell["source"]))
    return "  ".join(parts)


def estimate_left_s(pending: Sequence[str], running: dict[str, float],
                    known_s: dict[str, float], workers: int) -> tuple[float, int]:
    """Seconds left if every notebook takes its slowest known time, shared among ``workers``;
    and how many notebooks have no known time (the estimate leaves them out)."""
    left = [known_s[n] for n in pending if n in known_s]
    left += [max(known_s[n] - elapsed, 0.0) for n, elapsed in running.items() if n in known_s]
    unknown = sum(n not in known_s for n in [*pending, *running])
    return sum(left) / max(workers, 1), unknown


class ProgressView:
    """Redraws (terminal) or prints periodically (no terminal) the running notebooks' state."""

    def __init__(self, *, progress_dir: Path, total: int, workers: int,
                 known_s: dict[str, float], stream: IO[str] | None = None,
                 terminal: bool | None = None, interval_s: float = 30.0) -> None:
        self.stream = stream or sys.stdout
        self.terminal = self.stream.isatty() if terminal is None else terminal
        self.progress_dir, self.total, self.workers = progress_dir, total, workers
        self.known_s, self.interval_s = known_s, interval_s
        self._drawn = 0
        self._last_print = time.monotonic()

    def log(self, line: str) -> None:
        """A line that stays (a notebook finished), printed above the redrawn block."""
        self._clear()
        print(line, file=self.stream, flush=True)

    def _clear(self) -> None:
        if self.terminal and self._drawn:
            self.stream.write(f"\x1b[{self._drawn}F\x1b[J")
            self._drawn = 0

    def _overall(self, pending: Sequence[str], running: dict[str, float], done: int) -> str:
        left_s, unknown = estimate_left_s(pending, running, self.known_s, self.workers)
        text = f"{done}/{self.total} done, {len(running)} running"
        if left_s or not unknown:
            text += f", about {_duration(left_s)} left at the slowest known times"
        if unknown:
            text += f" (no time known yet for {unknown} notebook(s))"
        return text

    def update(self, pending: Sequence[str], running: dict[str, float], done: int) -> None:
        """``running``: notebook name → seconds since it started."""
        lines = [notebook_status(name, elapsed, self.progress_dir)
                 for name, elapsed in running.items()]
        if self.terminal:
            self._clear()
            block = [f"  {line}" for line in lines] + [
                f"  overall: {self._overall(pending, running, done)}"]
            width = 200
            self.stream.write("".join(f"{line[:width]}\n" for line in block))
            self.stream.flush()
            self._drawn = len(block)
        elif time.monotonic() - self._last_print >= self.interval_s:
            self._last_print = time.monotonic()
            for line in lines:
                print(f"[running] {line}", file=self.stream, flush=True)
            print(f"[overall] {self._overall(pending, running, done)}", file=self.stream,
                  flush=True)

    def close(self) -> None:
        self._clear()
