"""scripts/check_rendered.py: a real headless Chromium finds a figure that does not load and a
broken link; without Chromium the script says so and exits 0."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from repro.infra import paths

SCRIPT = paths.REPO_ROOT / "scripts" / "check_rendered.py"
PNG = bytes.fromhex("89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c489"
                    "0000000d49444154789c6360000002000154a24f5d0000000049454e44ae426082")


def _run(*arguments: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *arguments], capture_output=True,
                          text=True, timeout=120, env={**os.environ, **(env or {})})


def _site(root: Path, *, broken: bool) -> Path:
    (root / "figures").mkdir(parents=True)
    (root / "figures" / "ok.png").write_bytes(PNG)
    extra = "<img src='figures/gone.png'><a href='missing.html'>x</a>" if broken else ""
    (root / "page.html").write_text(f"<!doctype html><title>t</title><h1 id='top'>t</h1>"
                                    f"<img src='figures/ok.png'><a href='#top'>top</a>{extra}")
    (root / "REPORT.md").write_text("# r\n\n![f](figures/ok.png)\n\n[page](page.html)\n")
    return root


def test_without_chromium_it_says_so_and_does_not_fail(tmp_path: Path) -> None:
    result = _run(str(_site(tmp_path, broken=True)), env={"CHROMIUM": "/no/such/chromium"})
    assert result.returncode == 0
    assert "SKIPPED: Chromium is not installed" in result.stdout
    assert _run(str(tmp_path), "--require-chromium",
                env={"CHROMIUM": "/no/such/chromium"}).returncode == 2


@pytest.mark.skipif(not any(shutil.which(b) for b in ("chromium", "chromium-browser")),
                    reason="Debian's chromium is not installed (apt-get install chromium)")
def test_chromium_finds_broken_figures_and_links(tmp_path: Path) -> None:
    good = _run(str(_site(tmp_path / "good", broken=False)))
    assert good.returncode == 0, good.stdout + good.stderr
    assert "2 page(s) checked" in good.stdout and "no problem" in good.stdout
    bad = _run(str(_site(tmp_path / "bad", broken=True)))
    assert bad.returncode == 1
    assert "image 'figures/gone.png' did not load" in bad.stdout
    assert "link 'missing.html' points at a missing file" in bad.stdout
