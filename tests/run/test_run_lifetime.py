"""Children die with the run: SIGKILL (and SIGTERM, SIGINT) of the runner mid-notebook leaves
no process of the run and no file changing afterwards, and publishes nothing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import write_notebook

from repro.infra import paths

REPO_SRC = str(paths.REPO_ROOT / "src")
PARAMETERS = "scale = 'quick'\nseed = 0\ndevice = 'cpu'\nbuild_dir = None\n"

# writes a sidecar into its build_dir (the run's staging folder; no torch import, to stay
# quick), starts a spawn-multiprocessing worker (as the GMD training does) and a subprocess,
# then writes heartbeats until killed
HANGS = """
import json, multiprocessing, os, subprocess, sys, time
from pathlib import Path
claims = Path(build_dir) / "claims"
claims.mkdir(parents=True)
(claims / "GMD-A1.json").write_text(json.dumps({"id": "GMD-A1", "run_id": os.environ[
    "REPRO_RUN_ID"], "scale": "quick", "figures": []}))
beats = Path(os.environ["TEST_BEATS"])
pool_worker = multiprocessing.get_context("spawn").Process(target=time.sleep, args=(600,))
pool_worker.start()
child = subprocess.Popen([sys.executable, "-c",
    "import time, pathlib\\np = pathlib.Path(%r)\\nwhile True:\\n"
    "    p.write_text(str(time.time()))\\n    time.sleep(0.1)" % str(beats / "child")])
(beats / "pids").write_text(f"{os.getpid()} {pool_worker.pid} {child.pid}")
for _ in range(6000):
    (beats / "kernel").write_text(str(time.time()))
    time.sleep(0.1)
"""


def _notebook(path: Path, body: str) -> None:
    write_notebook(path, body, parameters=PARAMETERS)


def processes_of_run(runner_pid: int) -> list[int]:
    """Every live process whose environment names ``runner_pid`` as its runner."""
    found = []
    marker = f"REPRO_RUNNER_PID={runner_pid}".encode()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            environ = (entry / "environ").read_bytes()
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if marker in environ.split(b"\0") and state != "Z":
            found.append(int(entry.name))
    return found


def _describe(pid: int) -> str:
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[:4]
    except OSError:
        return "gone"
    return f"{command[:160]} state/ppid/pgrp/session {state}"


def _snapshot(*folders: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for folder in folders:
        for path in sorted(folder.rglob("*")) if folder.exists() else []:
            if path.is_file():
                stat = path.stat()
                out[str(path)] = (stat.st_mtime_ns, stat.st_size)
    return out


@pytest.fixture()
def hanging_run(tmp_path: Path):
    notebooks = tmp_path / "notebooks"
    notebooks.mkdir()
    _notebook(notebooks / "01_hangs.ipynb", HANGS)
    beats = tmp_path / "beats"
    beats.mkdir()
    env = {**os.environ, "REPRO_NOTEBOOKS_DIR": str(notebooks),
           "REPRO_BUILD_ROOT": str(tmp_path / "build"), "TEST_BEATS": str(beats),
           "PYTHONPATH": os.pathsep.join([REPO_SRC, os.environ.get("PYTHONPATH", "")])}
    log = open(tmp_path / "runner.log", "w")  # noqa: SIM115
    runner = subprocess.Popen([sys.executable, "-m", "repro", "reproduce", "--quick",
                               "--threads", "1"], env=env, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    deadline = time.monotonic() + 120
    while not (beats / "pids").exists() or not (beats / "child").exists():
        assert runner.poll() is None, (tmp_path / "runner.log").read_text()
        assert time.monotonic() < deadline, "the test notebook did not start in 120 s"
        time.sleep(0.2)
    started = set(map(int, (beats / "pids").read_text().split()))  # kernel, pool, child
    assert started <= set(processes_of_run(runner.pid)), "the check would not see them"
    yield runner, tmp_path
    for pid in processes_of_run(runner.pid):  # only if the test failed: clean up
        os.kill(pid, signal.SIGKILL)
    if runner.poll() is None:
        runner.kill()
        runner.wait()
    log.close()


def _assert_nothing_left(runner_pid: int, tmp_path: Path) -> None:
    deadline = time.monotonic() + 20  # SIGKILL is immediate; the slack is for a loaded machine
    while processes_of_run(runner_pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = {pid: _describe(pid) for pid in processes_of_run(runner_pid)}
    assert left == {}, "processes of the run survived the runner"
    build = tmp_path / "build"
    before = _snapshot(build, tmp_path / "beats")
    time.sleep(1.5)
    assert _snapshot(build, tmp_path / "beats") == before, "files changed after the run died"
    assert not (build / "quick" / "claims").exists(), "an unfinished notebook published"
    assert not (build / "quick" / "notebooks").exists()
    assert not (build / "quick" / "report").exists()


def test_sigkill_of_the_runner_kills_worker_kernel_and_its_children(hanging_run) -> None:
    runner, tmp_path = hanging_run
    os.kill(runner.pid, signal.SIGKILL)
    runner.wait()
    _assert_nothing_left(runner.pid, tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_sigterm_and_sigint_stop_the_run_and_publish_nothing(hanging_run, sig: int) -> None:
    runner, tmp_path = hanging_run
    os.kill(runner.pid, sig)
    assert runner.wait(timeout=30) == 128 + sig
    log = (tmp_path / "runner.log").read_text()
    assert f"stopped by {signal.Signals(sig).name}" in log
    assert "published nothing (01_hangs)" in log
    _assert_nothing_left(runner.pid, tmp_path)
