"""Armed in every kernel the runner starts, before the notebook's first cell.

The worker passes ``--IPKernelApp.exec_lines`` calling :func:`arm`; it

- registers the kernel's pid in the run's pid folder (``REPRO_RUN_PIDS_DIR``), so that a
  runner stopped by SIGINT/SIGTERM kills the kernel's process group (the kernel leads one:
  jupyter_client starts kernels with ``start_new_session``), workers of a multiprocessing pool
  included;
- kills that group as soon as the runner or the worker that started the kernel ends
  (``infra.lifetime.exit_when_gone``), which covers a ``kill -9`` of the runner, an
  out-of-memory kill and a CI timeout, where nothing is left to do the killing.

Outside the runner (no ``REPRO_RUNNER_PID``) it does nothing.
"""

from __future__ import annotations

import os
from pathlib import Path

from repro.infra import lifetime

RUNNER_PID = "REPRO_RUNNER_PID"
PIDS_DIR = "REPRO_RUN_PIDS_DIR"


def arm() -> bool:
    """Tie this kernel's life to the runner's and its worker's; False outside the runner."""
    runner = os.environ.get(RUNNER_PID)
    if not runner:
        return False
    pids_dir = os.environ.get(PIDS_DIR)
    if pids_dir:
        Path(pids_dir).mkdir(parents=True, exist_ok=True)
        (Path(pids_dir) / f"kernel-{os.getpid()}").write_text(str(os.getpid()))
    lifetime.exit_when_gone([int(runner), os.getppid()])
    return True
