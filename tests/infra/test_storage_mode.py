"""Files the package writes get the user's umask, not mkstemp's private 0600."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from repro.infra import storage


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_written_files_follow_the_umask(tmp_path: Path, umask: int, mode: int) -> None:
    previous = os.umask(umask)
    try:
        assert storage.current_umask() == umask
        written = [storage.write_json(tmp_path / "a.json", {"x": 1}),
                   storage.write_text(tmp_path / "b.md", "text"),
                   storage.write_bytes(tmp_path / "c.bin", b"\0")]
    finally:
        os.umask(previous)
    assert [stat.S_IMODE(p.stat().st_mode) for p in written] == [mode] * 3
