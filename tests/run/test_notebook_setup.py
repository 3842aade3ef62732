"""``run.notebook.setup_notebook``: a notebook's run settings come by one road.

The runner checks the parameters before any kernel starts; a notebook run by hand makes the
same checks (``run.params``) in ``setup_notebook``; the context carries what the notebook reads
(``ctx.data_dir`` absolute, ``ctx.threads`` the torch threads set); the build folder comes as
the ``build_dir`` parameter, never through the environment.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
import torch

from repro.infra import paths
from repro.run import notebook, worker
from repro.run.notebook import setup_notebook


@pytest.fixture()
def by_hand(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """No runner around (no run ID, no thread share); torch's threads restored afterwards."""
    monkeypatch.delenv("REPRO_RUN_ID", raising=False)
    monkeypatch.delenv("REPRO_TORCH_THREADS", raising=False)
    monkeypatch.setenv("REPRO_BUILD_ROOT", str(tmp_path / "build"))
    threads = torch.get_num_threads()
    yield tmp_path
    torch.set_num_threads(threads)


@pytest.mark.parametrize(("changed", "message"), [
    ({"scale": "full"}, "parameter scale='full' must be one of quick, standard, paper"),
    ({"seed": True}, "parameter seed must be int, got True (bool)"),
    ({"seed": -1}, "parameter seed=-1 is negative: a base seed is a whole number from 0"),
    ({"device": "meta"}, "parameter device='meta' must be cpu, cuda or cuda:N"),
    ({"data_dir": "no/such/folder"}, "parameter data_dir='no/such/folder' is not a folder"),
])
def test_by_hand_the_runners_checks_apply(by_hand: Path, changed: dict, message: str) -> None:
    standard = {"scale": "quick", "seed": 0, "device": "cpu", "build_dir": str(by_hand)}
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        setup_notebook(**{**standard, **changed})


def test_the_context_carries_what_the_notebook_reads(by_hand: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    stubs = paths.data_stubs_dir()
    monkeypatch.chdir(stubs.parent)
    monkeypatch.setenv("REPRO_BUILD_DIR", str(by_hand / "not read"))  # no such road any more
    monkeypatch.setenv("REPRO_TORCH_THREADS", "3")
    ctx = setup_notebook(scale="quick", seed=5, device="cpu", build_dir=None,
                         data_dir=stubs.name, max_threads=2)
    assert ctx.data_dir == stubs.resolve() and ctx.data_dir.is_absolute()
    assert ctx.build_dir == (by_hand / "build" / "quick").resolve()
    assert ctx.figures_dir.is_dir() and not (by_hand / "not read").exists()
    assert ctx.threads == 2 == torch.get_num_threads()
    assert ctx.run_id == "" and ctx.seed == 5 and ctx.quick
    other = setup_notebook(scale="quick", seed=5, device="cpu", build_dir=str(by_hand / "b"))
    assert other.data_dir is None and other.threads == 3 == torch.get_num_threads()
    assert other.build_dir == (by_hand / "b").resolve()
    with pytest.raises(ValueError, match="max_threads must be at least 1"):
        setup_notebook(scale="quick", seed=5, device="cpu", build_dir=None, max_threads=0)


def test_a_kernel_of_the_runner_is_not_checked_again(by_hand: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    def checked(_: dict) -> None:
        raise AssertionError("the runner checked these before the kernel started")

    monkeypatch.setattr(notebook, "check_standard_parameters", checked)
    monkeypatch.setenv("REPRO_RUN_ID", "20261204-quick-s0")
    ctx = setup_notebook(scale="quick", seed=0, device="cpu", build_dir=str(by_hand / "staging"))
    assert ctx.run_id == "20261204-quick-s0"


def test_the_worker_gives_its_kernel_no_build_folder_variable(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "environ", {})   # what the worker sets, and nothing else
    spec = worker.WorkerSpec(name="01_x", notebook="01_x.ipynb", output="out.ipynb",
                             staging=str(tmp_path), parameters={"build_dir": str(tmp_path)},
                             threads=2, timeout=60, run_id="r", runner_pid=1,
                             kernel_name="python3", progress_dir=str(tmp_path),
                             pids_dir=str(tmp_path))
    worker._prepare_environment(spec, str(tmp_path))
    assert os.environ["REPRO_TORCH_THREADS"] == "2" and os.environ["REPRO_RUN_ID"] == "r"
    assert not [name for name in os.environ if "BUILD" in name]
