"""One notebook, executed by papermill in a process of its own: ``python -m repro.run.worker
SPEC.json``. The runner starts it and reads ``result.json`` beside the executed notebook.

- It dies with the runner (``prctl(PR_SET_PDEATHSIG)``), and its kernel dies with either
  (``run.kernel_guard``, armed through ``--IPKernelApp.exec_lines``).
- The kernel talks to it over IPC sockets (``transport = "ipc"``), not TCP: nothing listens on
  a port, and ipykernel's "running over TCP without encryption" warning does not apply.
- Each code cell's start is written to ``<staging>/progress/<name>.cell.json`` (cell i of N);
  the library writes its stages to ``<name>.stage.json`` (``infra.progress``).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from repro.infra import lifetime, paths, progress
from repro.run import kernel_guard

GUARD_LINE = "__import__('repro.run.kernel_guard').run.kernel_guard.arm()"
ENGINE = "repro"


@dataclass(frozen=True)
class WorkerSpec:
    """What the runner asks a worker to do (written as JSON; keyword fields only)."""

    name: str
    notebook: str
    output: str
    staging: str
    parameters: dict[str, Any]
    threads: int
    timeout: int
    run_id: str
    runner_pid: int
    kernel_name: str
    progress_dir: str
    pids_dir: str


def read_spec(path: str | os.PathLike) -> WorkerSpec:
    return WorkerSpec(**json.loads(Path(path).read_text(encoding="utf-8")))


def write_spec(path: Path, spec: WorkerSpec) -> None:
    path.write_text(json.dumps(asdict(spec), indent=2), encoding="utf-8")


def _cell_reporter(nb_man: Any, cell_file: Path) -> None:
    """Make papermill's ``cell_start`` also write "code cell i of N" to ``cell_file``."""
    code_cells = [i for i, cell in enumerate(nb_man.nb.cells) if cell.cell_type == "code"]
    original = nb_man.cell_start

    def cell_start(cell: Any, cell_index: int | None = None, **kwargs: Any) -> Any:
        if cell_index in code_cells:
            first_line = next((line for line in cell.source.splitlines() if line.strip()), "")
            record = {"cell": code_cells.index(cell_index) + 1, "cells": len(code_cells),
                      "source": first_line[:60], "time": time.time()}
            tmp = cell_file.with_name(f".{cell_file.name}.tmp")
            tmp.write_text(json.dumps(record), encoding="utf-8")
            os.replace(tmp, cell_file)
        return original(cell, cell_index, **kwargs)

    nb_man.cell_start = cell_start


def _register_engine(cell_file: Path) -> None:
    from papermill.engines import NBClientEngine, papermill_engines

    class ProgressEngine(NBClientEngine):
        @classmethod
        def execute_managed_notebook(cls, nb_man: Any, kernel_name: str, **kwargs: Any) -> Any:
            _cell_reporter(nb_man, cell_file)
            return super().execute_managed_notebook(nb_man, kernel_name, **kwargs)

    papermill_engines.register(ENGINE, ProgressEngine)


def _ipc_kernel_manager() -> type:
    from jupyter_client.manager import AsyncKernelManager
    from traitlets import default

    class IPCKernelManager(AsyncKernelManager):
        """The kernel's sockets as files in the (private) runtime folder instead of TCP ports."""

        @default("transport")
        def _default_transport(self) -> str:
            return "ipc"

        @default("ip")
        def _default_ip(self) -> str:
            # jupyter_client's default ("kernel-ipc" in the working folder when no connection
            # file is named yet) is shared by kernels starting at once: their sockets collide
            return os.path.join(os.environ["JUPYTER_RUNTIME_DIR"], "kernel")

    return IPCKernelManager


def _prepare_environment(spec: WorkerSpec, runtime_dir: str) -> None:
    """What the kernel inherits beyond its parameters (its staging folder is its ``build_dir``
    parameter): thread counts for torch and the BLAS pools, the run ID, the progress and
    lifetime channels, the runtime folder and the figure backend."""
    for variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                     "REPRO_TORCH_THREADS"):
        os.environ[variable] = str(spec.threads)
    os.environ["REPRO_RUN_ID"] = spec.run_id
    os.environ[progress.ENV_VARIABLE] = str(Path(spec.progress_dir) / f"{spec.name}.stage.json")
    os.environ[kernel_guard.RUNNER_PID] = str(spec.runner_pid)
    os.environ[kernel_guard.PIDS_DIR] = spec.pids_dir
    os.environ["JUPYTER_RUNTIME_DIR"] = runtime_dir  # short, private: IPC socket paths
    # the kernel's inline backend, so that plt.show() puts each figure into the executed
    # notebook (its rendered HTML is what a reader of results/ sees); not Agg, which drops them
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"


def execute(spec: WorkerSpec) -> dict[str, Any]:
    """Run the notebook; returns ``{"ok", "seconds", "error"}`` (also written to result.json)."""
    import papermill
    from papermill.exceptions import PapermillExecutionError

    runtime_dir = tempfile.mkdtemp(prefix="repro-k")
    _prepare_environment(spec, runtime_dir)
    cell_file = Path(spec.progress_dir) / f"{spec.name}.cell.json"
    _register_engine(cell_file)
    start = time.perf_counter()
    error = ""
    try:
        papermill.execute_notebook(
            spec.notebook, spec.output, parameters=spec.parameters, engine_name=ENGINE,
            kernel_name=spec.kernel_name, progress_bar=False, log_output=False,
            cwd=str(paths.notebooks_dir()), execution_timeout=spec.timeout, start_timeout=120,
            kernel_manager_class=_ipc_kernel_manager(),
            extra_arguments=[f"--IPKernelApp.exec_lines={GUARD_LINE}"])
    except PapermillExecutionError as failure:
        source = failure.source.strip().splitlines()
        first = source[0] if source else ""
        error = (f"notebook {spec.name}, cell {failure.cell_index} of the executed notebook "
                 f"(starting {first!r}) raised {failure.ename}: {failure.evalue}")
    except Exception as failure:  # kernel death, timeout, missing kernel
        error = f"notebook {spec.name}: {type(failure).__name__}: {failure}"
    finally:
        shutil.rmtree(runtime_dir, ignore_errors=True)
    result = {"ok": not error, "seconds": time.perf_counter() - start, "error": error}
    result_file = Path(spec.staging) / "result.json"
    tmp = result_file.with_name(".result.json.tmp")
    tmp.write_text(json.dumps(result), encoding="utf-8")
    os.replace(tmp, result_file)
    return result


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    spec = read_spec(argv[0])
    lifetime.die_with_parent(expected_parent=spec.runner_pid)
    return 0 if execute(spec)["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
