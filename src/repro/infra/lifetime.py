"""Child processes that die with the run that started them (Linux).

A ``kill -9`` of the runner, an out-of-memory kill or a CI timeout gives the runner no chance
to stop its children, and a kernel left running goes on writing files that the next run reads.
Two mechanisms close that gap, both needing nothing from the dead process:

- :func:`die_with_parent`: ``prctl(PR_SET_PDEATHSIG)`` — the kernel sends the process a signal
  when the thread that forked it exits (``man 2 prctl``). The runner starts its notebook
  workers from its main thread, so they die with it.
- :func:`exit_when_gone`: a daemon thread waits on ``pidfd_open`` handles (``man 2
  pidfd_open``) of processes that must outlive this one; when one ends, the process kills its
  own process group (itself and the workers it started, e.g. a multiprocessing pool) — the
  kernels jupyter_client starts lead their own group (``start_new_session``).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import select
import signal
import threading
import time
from collections.abc import Iterable

__all__ = ["PR_SET_PDEATHSIG", "die_with_parent", "exit_when_gone", "kill_group",
           "pid_alive"]

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(sig: int = signal.SIGKILL, expected_parent: int | None = None) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent exits.

    If ``expected_parent`` is given and the parent is already another process (the expected
    one died before the call), the process exits at once. Returns False where prctl is not
    available (not Linux); the caller then relies on :func:`exit_when_gone`.
    """
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        armed = libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        armed = False
    if expected_parent is not None and os.getppid() != expected_parent:
        os._exit(1)
    return armed


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (zombies count as gone)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def kill_group(pid: int, sig: int = signal.SIGKILL) -> None:
    """Signal the process group led by ``pid`` (nothing if it is gone)."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, sig)


def _die() -> None:
    """Kill this process and, when it leads its own group, everything in that group."""
    if os.getpgrp() == os.getpid():
        kill_group(os.getpid())
    os.kill(os.getpid(), signal.SIGKILL)


def _wait_pidfds(pids: list[int]) -> None:
    handles = []
    for pid in pids:
        try:
            handles.append(os.pidfd_open(pid))
        except ProcessLookupError:
            _die()
        except OSError:  # no pidfd support (old kernel, seccomp): poll instead
            _wait_polling(pids, 0.5)
            return
    poller = select.poll()
    for handle in handles:
        poller.register(handle, select.POLLIN)
    while not poller.poll():
        pass
    _die()


def _wait_polling(pids: list[int], interval_s: float) -> None:
    while all(pid_alive(pid) for pid in pids):
        time.sleep(interval_s)
    _die()


def exit_when_gone(pids: Iterable[int], *, interval_s: float = 0.5) -> threading.Thread:
    """Start a daemon thread that kills this process (and its group, if it leads one) as soon
    as any of ``pids`` ends. Uses pidfds where the kernel has them, else polls."""
    pids = [int(pid) for pid in pids if int(pid) > 1]
    target = _wait_pidfds if hasattr(os, "pidfd_open") else _wait_polling
    args: tuple = (pids,) if target is _wait_pidfds else (pids, interval_s)
    thread = threading.Thread(target=target, args=args, name="repro-exit-when-gone",
                              daemon=True)
    thread.start()
    return thread
