"""Cached artefacts carry a checksum verified on load: a truncated, changed or unreadable
``model.pt`` is moved aside and retrained with a warning naming it; lock-only folders left by
failed runs are cleaned. Cache keys are untouched (the key pins live in tests/core)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
import torch
from torch import nn

from repro.infra import cache

CONFIG = {"kind_of": "integrity test", "width": 3}


@pytest.fixture()
def cache_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("REPRO_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _train_counter() -> tuple[list[int], object]:
    calls: list[int] = []

    def train(module: nn.Module) -> nn.Module:
        calls.append(1)
        with torch.no_grad():
            module.weight.fill_(float(len(calls)))
        return module

    return calls, train


def _entry() -> Path:
    return cache._artifact_dir("integrity", CONFIG)


def test_checksum_is_recorded_and_a_clean_entry_loads(cache_root: Path) -> None:
    calls, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    recorded = cache.storage.read_json(_entry() / cache.CHECKSUMS)["model.pt"]
    assert recorded == cache.file_checksum(_entry() / "model.pt")
    model = cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    assert calls == [1] and float(model.weight[0, 0].detach()) == 1.0


@pytest.mark.parametrize("damage", ["truncated", "changed", "empty"])
def test_a_damaged_model_is_moved_aside_and_retrained_saying_so(cache_root: Path,
                                                                damage: str) -> None:
    calls, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    weights = _entry() / "model.pt"
    payload = weights.read_bytes()
    weights.write_bytes({"truncated": payload[: len(payload) // 2],
                         "changed": payload[:-1] + bytes([payload[-1] ^ 1]),
                         "empty": b""}[damage])
    with pytest.warns(RuntimeWarning, match=r"model\.pt is .* bytes .*moved it aside to .*"
                      r"model\.pt\.corrupt-.* and retraining"):
        model = cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    assert calls == [1, 1] and float(model.weight[0, 0].detach()) == 2.0
    assert len(list(_entry().glob("model.pt.corrupt-*"))) == 1
    assert cache.verify_checksum(_entry(), "model.pt") is None


def test_an_entry_from_before_checksums_is_checked_by_loading_it(cache_root: Path) -> None:
    calls, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    (_entry() / cache.CHECKSUMS).unlink()                    # an old entry: no checksums
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    assert calls == [1] and (_entry() / cache.CHECKSUMS).is_file()   # adopted
    (_entry() / cache.CHECKSUMS).unlink()
    (_entry() / "model.pt").write_bytes(b"PK\x03\x04 not a zip")    # old and unreadable
    with pytest.warns(RuntimeWarning, match=r"model\.pt cannot be read"):
        cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    assert calls == [1, 1]


def test_weights_that_do_not_fit_the_model_name_the_file_and_the_fix(cache_root: Path) -> None:
    _, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    with pytest.raises(cache.CorruptArtifactError, match=r"(?s)model\.pt does not fit .* delete "):
        cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 4), train)


def test_lock_only_folders_and_stale_temporaries_are_cleaned(cache_root: Path) -> None:
    def fail(module: nn.Module) -> nn.Module:
        raise RuntimeError("training failed")

    with pytest.raises(RuntimeError):
        cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), fail)
    assert [p.name for p in _entry().iterdir()] == [".lock"]
    _, train = _train_counter()
    cache.load_or_train("integrity", {"other": 1}, lambda: nn.Linear(3, 3), train)
    other = cache._artifact_dir("integrity", {"other": 1})
    stale = other / ".model.pt.abc.tmp"
    stale.write_bytes(b"half")
    os.utime(stale, (time.time() - 3600, time.time() - 3600))
    removed = cache.clean_cache()
    assert _entry() in removed and stale in removed
    assert not _entry().exists() and (other / "model.pt").is_file()
    with cache.artifact_lock(_entry()):            # a folder in use is left alone
        assert cache.clean_cache() == []


def test_the_move_aside_warning_is_sent_to_the_runner(cache_root: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue #35 case 9: under a runner the warning also goes to its notices file (the
    runner prints it and records it in the report's provenance)."""
    from repro.infra import progress

    stage = tmp_path / "nb.stage.json"
    monkeypatch.setenv(progress.ENV_VARIABLE, str(stage))
    calls, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    (_entry() / "model.pt").write_bytes(b"garbage")
    with pytest.warns(RuntimeWarning, match="moved it aside"):
        cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    [notice] = progress.notices(stage)
    assert notice.startswith(f"cache: {_entry() / 'model.pt'}") and "retraining" in notice


def test_damaged_entries_are_found_before_a_run_reads_them(cache_root: Path) -> None:
    """``check_entries`` (the runner's, before any kernel starts): a truncated model, garbled
    JSON and a generated data set's cut clip are moved aside, so the run rebuilds them; an
    entry being written (its lock held) and clean entries are left alone."""
    import fcntl

    import numpy as np

    calls, train = _train_counter()
    cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    weights = _entry() / "model.pt"
    weights.write_bytes(weights.read_bytes()[:100])
    data = cache.cached_artifact_dir("emg_like", {"n": 1})
    (data / "meta.json").write_text('{"captions": [', encoding="utf-8")
    np.save(data / "features.npy", np.zeros((4, 3), dtype=np.float32))
    dataset = cache_root / "datasets" / "abc"
    (dataset / "new_joint_vecs").mkdir(parents=True)
    np.save(dataset / "new_joint_vecs" / "000000.npy", np.zeros((40, 263), dtype=np.float32))
    clip = dataset / "new_joint_vecs" / "000001.npy"
    np.save(clip, np.zeros((40, 263), dtype=np.float32))
    clip.write_bytes(clip.read_bytes()[:500])
    (dataset / "dataset.json").write_text("{}", encoding="utf-8")
    busy = cache.cached_artifact_dir("busy", {"n": 2})
    (busy / "meta.json").write_text("garbled", encoding="utf-8")

    beside = cache.cached_artifact_dir("beside", {"n": 3})      # a sound model, garbled metrics
    cache.load_or_train("beside", {"n": 3}, lambda: nn.Linear(3, 3), train)
    (beside / "metrics.json").write_text("[", encoding="utf-8")

    with open(busy / ".lock", "w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        messages = cache.check_entries()
    assert len(messages) == 6 and all("before the run, which rebuilds it" in m for m in messages)
    assert not (beside / "model.pt").exists()                   # retrained, metrics rewritten
    assert any(f"{weights} is 100 bytes, but" in m for m in messages)
    assert any(f"{data / 'meta.json'} cannot be read" in m for m in messages)
    assert any(f"{clip} cannot be read" in m for m in messages)
    assert not weights.exists() and not (data / "meta.json").exists() and not clip.exists()
    assert (data / "features.npy").exists()
    assert (dataset / "new_joint_vecs" / "000000.npy").exists()
    assert not (dataset / "dataset.json").exists()            # the data set is generated again
    assert (busy / "meta.json").exists()                        # being written: left alone
    [later] = cache.check_entries()                             # its lock released
    assert f"{busy / 'meta.json'} cannot be read" in later and cache.check_entries() == []
    model = cache.load_or_train("integrity", CONFIG, lambda: nn.Linear(3, 3), train)
    assert calls == [1, 1, 1] and float(model.weight[0, 0].detach()) == 3.0   # retrained


def test_a_trained_model_is_returned_as_a_later_run_loads_it(tmp_path: Path) -> None:
    """Training returns the saved weights in a fresh module, as a warm run loads them, so the
    two compute alike to the last bit; state kept outside the weights does not come back."""
    def train(module: nn.Module) -> nn.Module:
        with torch.no_grad():
            module.weight.add_(1.0)
        module.scratch = "left by training"   # not in the state dict
        return module

    built: list[nn.Module] = []

    def build() -> nn.Module:
        built.append(nn.Linear(3, 2))
        return built[-1]

    config = {"kind": "toy"}
    os.environ["REPRO_CACHE_DIR"] = str(tmp_path)
    try:
        cold = cache.load_or_train("toy", config, build, train)
        warm = cache.load_or_train("toy", config, build, train)
    finally:
        del os.environ["REPRO_CACHE_DIR"]
    assert cold is not built[0] and not hasattr(cold, "scratch")
    assert all(torch.equal(a, b) for a, b in zip(cold.state_dict().values(),
                                                  warm.state_dict().values(), strict=True))
