"""Cached artefacts keyed by a hash of their full configuration (DESIGN.md "Caches").

Layout: ``cache_dir()/<kind>/<hash>/`` holding ``config.json`` (the canonical config),
``model.pt`` (a state dict), ``metrics.json`` and ``checksums.json`` (sha256 and size of each
payload file). ``model.pt`` is written before ``checksums.json``; an entry is complete when
both are there and agree. Every file goes through ``storage.atomic_open``.

Integrity: a payload whose checksum does not match, or that cannot be read, is moved aside
(``model.pt.corrupt-<UTC time>``, kept for inspection) and the model retrained, with a warning
naming the file (also sent to the runner, which prints it and records it in the report's
provenance: ``progress.notice``); :func:`clean_cache` removes folders a failed run left
holding only ``.lock``.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import fcntl
import hashlib
import json
import os
import re
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn

from repro.infra import paths, progress, storage

__all__ = ["CHECKSUMS", "CorruptArtifactError", "artifact_lock", "cached_artifact_dir",
           "canonical_json", "check_entries", "clean_cache", "config_hash", "file_checksum",
           "fingerprint", "holds_models", "load_or_train", "verify_checksum", "write_checksum"]

CHECKSUMS = "checksums.json"

_KIND_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def _canonical_default(value: Any) -> Any:
    try:
        return storage.json_default(value)
    except TypeError:
        raise ValueError(f"config value of type {type(value).__name__} cannot be hashed; use "
                         "JSON types (dict, list, str, int, float, bool, None)") from None


def canonical_json(config: dict[str, Any]) -> str:
    """Sorted keys, no whitespace, tuples as lists, numpy scalars as numbers; NaN rejected."""
    if not isinstance(config, dict):
        raise ValueError(f"config must be a dict, got {type(config).__name__}")
    try:
        return json.dumps(config, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                          allow_nan=False, default=_canonical_default)
    except TypeError as error:     # e.g. non-string dict keys mixed with strings
        raise ValueError(f"config cannot be written as canonical JSON: {error}") from error


def fingerprint(*parts: Any, digits: int | None = None, with_layout: bool = False) -> str:
    """sha256 over ``parts`` in order: the package's one content hash for cache keys.

    An array (numpy or torch) contributes its C-contiguous bytes, preceded by its shape and
    dtype when ``with_layout``; ``bytes`` as they are; a ``str`` as UTF-8; anything else as
    ``json.dumps`` of it. ``digits`` keeps that many leading hex digits (None: all 64).
    """
    digest = hashlib.sha256()
    for part in parts:
        if isinstance(part, Tensor | np.ndarray):
            value = np.ascontiguousarray(part.detach().cpu().numpy() if isinstance(part, Tensor)
                                         else part)
            if with_layout:
                digest.update(f"{value.shape}{value.dtype}".encode())
            digest.update(value.tobytes())
        elif isinstance(part, bytes):
            digest.update(part)
        elif isinstance(part, str):
            digest.update(part.encode("utf-8"))
        else:
            digest.update(json.dumps(part).encode("utf-8"))
    text = digest.hexdigest()
    return text[:digits] if digits else text


def config_hash(config: dict[str, Any]) -> str:
    """The first 16 hex digits of sha256(canonical JSON of ``config``)."""
    return fingerprint(canonical_json(config), digits=16)


def _normalised(config: dict[str, Any]) -> Any:
    """The config as it reads back from JSON (tuples → lists etc.), for comparisons."""
    return json.loads(canonical_json(config))


def cached_artifact_dir(kind: str, config: dict[str, Any]) -> Path:
    """``cache_dir()/kind/<config_hash>/``, created, with ``config.json`` written beside."""
    directory = _artifact_dir(kind, config)
    config_file = directory / "config.json"
    if not config_file.exists() or _read_config(config_file) != _normalised(config):
        storage.write_json(config_file, _normalised(config))
    return directory


def _artifact_dir(kind: str, config: dict[str, Any]) -> Path:
    if not isinstance(kind, str) or not _KIND_PATTERN.match(kind):
        raise ValueError(f"cache kind must be a simple folder name like 'gmd_traj', got {kind!r}")
    return paths.cache_dir() / kind / config_hash(config)


def _read_config(path: Path) -> Any:
    try:
        return storage.read_json(path)
    except (OSError, ValueError):
        return None


@contextlib.contextmanager
def artifact_lock(directory: Path) -> Iterator[None]:
    """An exclusive lock on a cache entry, so notebooks running in parallel that need the same
    model train it once: the second waits, then loads what the first saved."""
    directory.mkdir(parents=True, exist_ok=True)
    with open(directory / ".lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


class CorruptArtifactError(ValueError):
    """A cached file that is not what was written: its message names the file and the fix."""


def file_checksum(path: Path) -> dict[str, Any]:
    """``{"sha256": hex digest, "bytes": size}`` of a file, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    size = 0
    with open(path, "rb") as handle:
        while block := handle.read(1 << 20):
            digest.update(block)
            size += len(block)
    return {"sha256": digest.hexdigest(), "bytes": size}


def write_checksum(directory: Path, name: str) -> None:
    """Record the checksum of ``directory/name`` in ``directory/checksums.json``."""
    directory = Path(directory)
    recorded = _read_checksums(directory) or {}
    recorded[name] = file_checksum(directory / name)
    storage.write_json(directory / CHECKSUMS, recorded)


def _read_checksums(directory: Path) -> dict[str, Any] | None:
    try:
        recorded = storage.read_json(directory / CHECKSUMS)
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        return {}
    return recorded if isinstance(recorded, dict) else {}


def verify_checksum(directory: Path, name: str) -> str | None:
    """What is wrong with ``directory/name`` against its recorded checksum, or None if it
    matches. An entry written before checksums existed (no ``checksums.json``) is "unverified"
    and passes here; its load is the check (and records the checksum)."""
    directory = Path(directory)
    recorded = _read_checksums(directory)
    if recorded is None:
        return None
    if name not in recorded:
        return f"{directory / CHECKSUMS} has no checksum for {name}"
    try:
        actual = file_checksum(directory / name)
    except OSError as error:
        return f"{directory / name} cannot be read ({error})"
    expected = recorded[name]
    if actual != expected:
        return (f"{directory / name} is {actual['bytes']} bytes with sha256 "
                f"{actual['sha256'][:12]}…, but {expected.get('bytes')} bytes with sha256 "
                f"{str(expected.get('sha256'))[:12]}… were written (truncated or changed)")
    return None


def _move_aside(path: Path, problem: str) -> Path:
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%SZ")
    aside = path.with_name(f"{path.name}.corrupt-{stamp}")
    os.replace(path, aside)
    message = (f"cache: {problem}; moved it aside to {aside} and retraining (delete that file "
               "once inspected)")
    warnings.warn(message, RuntimeWarning, stacklevel=3)
    progress.notice(message)  # under the runner: its terminal and the report's provenance
    return aside


def clean_cache(root: Path | None = None, *, tmp_age_s: float = 600.0) -> list[Path]:
    """Remove what failed runs left in the cache: entry folders holding only ``.lock`` and
    ``.*.tmp`` files of interrupted writes older than ``tmp_age_s``. A folder whose lock is
    held (a model training now) is left alone. Returns the removed paths."""
    root = Path(root) if root is not None else paths.cache_dir()
    removed: list[Path] = []
    if not root.is_dir():
        return removed
    now = time.time()
    for lock in sorted(root.glob("*/*/.lock")):
        directory = lock.parent
        with open(lock, "a") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                continue  # in use
            for tmp in directory.glob(".*.tmp"):
                with contextlib.suppress(OSError):
                    if now - tmp.stat().st_mtime > tmp_age_s:
                        tmp.unlink()
                        removed.append(tmp)
            if [p.name for p in directory.iterdir()] == [".lock"]:
                lock.unlink()
                with contextlib.suppress(OSError):
                    directory.rmdir()
                removed.append(directory)
    return removed


#: the files a complete entry of the dataset kind is checked by (its clips' arrays too)
_DATASET_FOLDERS = ("new_joint_vecs", "new_joints")


def _npy_complete(path: Path, size: int) -> bool:
    """Whether ``path`` starts with a ``.npy`` header and is as long as that header says."""
    try:
        with open(path, "rb") as handle:
            version = np.lib.format.read_magic(handle)
            read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                    else np.lib.format.read_array_header_2_0)
            shape, _, dtype = read(handle)
            start = handle.tell()
    except (ValueError, OSError, EOFError):
        return False
    return not dtype.hasobject and size == start + dtype.itemsize * int(np.prod(shape))


def _file_problem(path: Path, recorded: Any = None) -> str | None:
    """What is wrong with cache file ``path`` that its size and head tell — a size other
    than ``recorded`` (its checksums.json row), JSON that does not parse, a ``.npy`` whose
    header or length is wrong, a zip (``.npz``, ``.pt``) whose directory is gone —; None if
    nothing. The full checksum is verified when the file is loaded."""
    try:
        size = path.stat().st_size
    except OSError as error:
        return f"{path} cannot be read ({error.strerror})"
    if isinstance(recorded, dict) and recorded.get("bytes") not in (None, size):
        return (f"{path} is {size} bytes, but {recorded['bytes']} were written (truncated or "
                "changed)")
    try:
        if path.suffix == ".json":
            storage.read_json(path)
        elif path.suffix == ".npy" and not _npy_complete(path, size):
            storage.read_npy(path)   # raises, naming what is wrong
        elif path.suffix in (".npz", ".pt"):
            with zipfile.ZipFile(path):
                pass
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        return f"{path} cannot be read ({type(error).__name__}: {error})"
    return None


def _entry_problems(directory: Path) -> list[tuple[Path, str]]:
    """(file, problem) of one complete entry: its own files and, for a generated data set,
    its clips' arrays."""
    recorded = _read_checksums(directory) or {}
    files = [p for p in sorted(directory.iterdir()) if p.is_file() and not p.name.startswith(".")
             and ".corrupt-" not in p.name]
    if directory.parent.name == "datasets":
        files += [p for folder in _DATASET_FOLDERS for p in sorted((directory / folder).glob(
            "*.npy"))]
    problems = []
    for path in files:
        problem = _file_problem(path, recorded.get(path.name))
        if problem:
            problems.append((path, problem))
    return problems


def holds_models(root: Path | None = None) -> bool:
    """Whether the cache holds a complete trained model (a ``model.pt`` with its
    ``checksums.json``): a run that starts without one trains everything, cold."""
    root = Path(root) if root is not None else paths.cache_dir()
    return root.is_dir() and any((entry.parent / "model.pt").is_file()
                                 for entry in root.glob(f"*/*/{CHECKSUMS}"))


def check_entries(root: Path | None = None) -> list[str]:
    """Damaged files of the cache's complete entries, found before a run reads them (the
    runner calls this before any kernel starts): each is moved aside (``<name>.corrupt-<UTC
    time>``, kept for inspection) so that the run rebuilds the entry — a model retrained
    (its ``model.pt`` moved aside too), a data entry rebuilt, a generated data set (its
    ``dataset.json`` moved aside too) generated again. An entry whose lock is held (being
    written now) and a data set without its ``dataset.json`` (incomplete: generated again
    anyway) are left alone. Returns one message per file moved aside."""
    root = Path(root) if root is not None else paths.cache_dir()
    messages: list[str] = []
    for directory in sorted(p for p in root.glob("*/*") if p.is_dir()) if root.is_dir() else []:
        dataset = directory.parent.name == "datasets"
        if dataset and not (directory / "dataset.json").is_file():
            continue
        with contextlib.ExitStack() as stack:
            lock = directory / ".lock"
            if lock.exists():
                handle = stack.enter_context(open(lock, "a"))
                try:
                    fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except BlockingIOError:
                    continue  # being trained or written now
            problems = _entry_problems(directory)
            for path, problem in problems:
                messages.append(_set_aside(path, problem))
            # what makes the entry rebuilt whole (its metrics.json beside a sound model, a
            # data set's other clips): the model retrained, the data set generated again
            marker = directory / ("dataset.json" if dataset else "model.pt")
            if problems and marker.is_file():
                messages.append(_set_aside(marker, f"{directory} holds damaged files"))
    return messages


def _set_aside(path: Path, problem: str) -> str:
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y%m%dT%H%M%SZ")
    aside = path.with_name(f"{path.name}.corrupt-{stamp}")
    os.replace(path, aside)
    return (f"cache: {problem}; moved it aside to {aside} before the run, which rebuilds it "
            "(delete that file once inspected)")


def load_or_train(kind: str, config: dict[str, Any], build_model: Callable[[], nn.Module],
                  train: Callable[[nn.Module], Any], *, device: str | torch.device = "cpu",
                  retrain: bool = False) -> nn.Module:
    """Load ``cache/kind/hash/model.pt`` if it exists for this exact config; else train and save.

    ``build_model()`` makes a fresh (untrained) module; ``train(module)`` returns the trained
    module, or ``(module, metrics)`` with a JSON-able dict (e.g. losses), written to
    ``metrics.json``. The state dict is loaded with ``map_location=device``; the returned
    module is on ``device`` in eval mode. ``retrain=True`` ignores an existing entry.
    """
    device = torch.device(device)
    directory = _artifact_dir(kind, config)
    with artifact_lock(directory):
        return _load_or_train_locked(directory, config, build_model, train, device, retrain)


def _load_or_train_locked(directory: Path, config: dict[str, Any],
                          build_model: Callable[[], nn.Module], train: Callable[[nn.Module], Any],
                          device: torch.device, retrain: bool) -> nn.Module:
    kind = directory.parent.name
    weights_file = directory / "model.pt"
    if not retrain and weights_file.exists() and _read_config(
            directory / "config.json") == _normalised(config):
        problem = verify_checksum(directory, weights_file.name)
        if problem is None:
            try:
                state = torch.load(weights_file, map_location=device, weights_only=True)
            except Exception as error:  # truncated zip, unpickling error, EINVAL
                problem = f"{weights_file} cannot be read ({type(error).__name__}: {error})"
        if problem is None:
            model = build_model()
            try:
                model.load_state_dict(state)
            except RuntimeError as error:
                raise CorruptArtifactError(
                    f"{weights_file} does not fit the model its config builds ({error}); the "
                    f"cache key misses a change of the model code: delete {directory} to "
                    "retrain it") from None
            if _read_checksums(directory) is None:
                write_checksum(directory, weights_file.name)  # an entry from before checksums
            return model.to(device).eval()
        _move_aside(weights_file, problem)

    result = train(build_model().to(device))
    model, metrics = result if isinstance(result, tuple) else (result, None)
    if not isinstance(model, nn.Module):
        raise ValueError(f"train must return an nn.Module or (nn.Module, dict), got "
                         f"{type(model).__name__}")
    cached_artifact_dir(kind, config)      # writes config.json
    if metrics is not None:
        storage.write_json(directory / "metrics.json", metrics)
    with storage.atomic_open(weights_file, "wb") as handle:
        torch.save({k: v.detach().cpu() for k, v in model.state_dict().items()}, handle)
    write_checksum(directory, weights_file.name)
    # What a later run loads: the saved weights in a fresh module, so that a run that trains
    # and one that loads compute with the same tensors (their memory layout and autograd
    # state included) and give the same numbers to the last bit.
    fresh = build_model()
    fresh.load_state_dict(torch.load(weights_file, map_location=device, weights_only=True))
    return fresh.to(device).eval()
