"""Atomic writes: a reader never sees a half-written file, and a failure leaves the old one.

Every file the package writes (sidecars, caches, reports, datasets) goes through here:
write to a temporary file in the same folder, flush and fsync, then ``os.replace``. The file
gets the mode a plain ``open`` would give it (0666 less the user's umask), not ``mkstemp``'s
private 0600.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np


def current_umask() -> int:
    """The process's umask, read without changing it (``/proc/self/status``; else set and
    restore, which is not thread-safe but only runs where /proc is missing)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """The mode ``open(path, "w")`` would create a file with: 0666 less the umask."""
    return 0o666 & ~current_umask()


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kwargs: Any) -> Iterator[IO]:
    """Open a temporary sibling of ``path`` for writing; on success it replaces ``path``."""
    if "r" in mode or "a" in mode:
        raise ValueError(f"atomic_open writes whole files; mode {mode!r} is not supported")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, file_mode())
        with os.fdopen(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def free_bytes(path: str | os.PathLike) -> int:
    """Free bytes on the disk holding ``path`` (its nearest existing folder); -1 if unknown."""
    folder = Path(path)
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return -1


def write_problem(error: OSError) -> str:
    """An ``OSError`` of a write in words: the file, the system's reason and what to do (a
    full disk: free space; no permission or a read-only disk: a writable folder)."""
    where = error.filename or "a file"
    reason = error.strerror or str(error)
    if error.errno in (errno.ENOSPC, errno.EDQUOT):
        free = free_bytes(where) if error.filename else -1
        room = f"; {free / 2**20:.1f} MiB free there now" if free >= 0 else ""
        return (f"cannot write {where}: {reason} (the disk is full{room}); free space on it "
                "and rerun")
    if error.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return (f"cannot write {where}: {reason}; make its folder writable for this user, or "
                "point REPRO_BUILD_ROOT (and REPRO_CACHE_DIR) at a writable folder")
    return f"cannot write {where}: {reason}"


def json_default(value: Any) -> Any:
    """JSON for numpy scalars and arrays, paths, sets (sorted) and tuples."""
    if isinstance(value, set | frozenset):
        return sorted(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, tuple):
        return list(value)
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def write_json(path: str | os.PathLike, data: Any) -> Path:
    """Write ``data`` as indented JSON, atomically (numpy scalars and arrays become lists)."""
    with atomic_open(path, "w", encoding="utf-8") as handle:
        json.dump(data, handle, indent=2, default=json_default, allow_nan=True)
        handle.write("\n")
    return Path(path)


def read_json(path: str | os.PathLike) -> Any:
    with open(path, encoding="utf-8") as handle:
        return json.load(handle)


def read_npy(path: str | os.PathLike) -> np.ndarray:
    """``np.load`` of one array (never a pickle); a file that is not a readable ``.npy`` raises
    ValueError naming it, what is wrong and what to do (numpy's own messages name no file,
    and its allow_pickle hint is the wrong advice for a damaged array).

    FileNotFoundError passes through unchanged."""
    try:
        array = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except EOFError as error:  # an empty file
        reason = f"is empty or cut short ({error})"
    except (ValueError, OSError) as error:
        text = str(error)
        if "contains pickled" in text:  # no .npy header: numpy took it for a pickle
            reason = ("is not a .npy array: it does not start with numpy's header (garbled, "
                      "or not written by numpy.save)")
        elif "Object arrays" in text:
            reason = "holds Python objects, not numbers"
        else:
            reason = f"cannot be read as a .npy array (truncated or damaged: {text})"
    else:
        if isinstance(array, np.ndarray):
            return array
        reason = "holds several arrays (an .npz archive), not one .npy array"
    raise ValueError(f"{path} {reason}; replace it with the original file") from None


def write_text(path: str | os.PathLike, text: str) -> Path:
    with atomic_open(path, "w", encoding="utf-8") as handle:
        handle.write(text)
    return Path(path)


def write_npy(path: str | os.PathLike, array: np.ndarray) -> Path:
    with atomic_open(path, "wb") as handle:
        np.save(handle, array)
    return Path(path)


def write_bytes(path: str | os.PathLike, payload: bytes) -> Path:
    with atomic_open(path, "wb") as handle:
        handle.write(payload)
    return Path(path)
