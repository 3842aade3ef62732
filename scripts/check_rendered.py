#!/usr/bin/env python3
"""Open the rendered results in a real headless browser and check what a reader would see.

    python scripts/check_rendered.py [FOLDER_OR_FILE ...]     (default: results/ and
                                                               build/report/)

Every ``*.html`` page below the folders (the executed notebooks, the report's index.html) and
every ``REPORT.md`` (shown through a minimal HTML page with its images and links) is loaded in
headless Chromium, Debian's ``chromium`` package (``apt-get install chromium``). A page passes
when every image has loaded (``complete`` and a natural width above 0), every link to a file
points at one that exists, and every in-page anchor (``#id``) names an element of the page;
links to other sites are listed, not followed (no network is assumed).

Chromium is driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``: JSON
messages separated by NUL on file descriptors 3 and 4), so nothing beyond the standard library
is needed. Without Chromium the script says so and exits 0 (``--require-chromium``: exit 2).
Exit 1 when a page has a problem.
"""

from __future__ import annotations

import argparse
import fcntl
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import unquote, urlparse

REPO = Path(__file__).resolve().parents[1]
BROWSERS = ("chromium", "chromium-browser", "google-chrome")
PAGE_SCRIPT = """(() => {
  const images = Array.from(document.images).map(i => ({
      src: (i.getAttribute('src') || '').slice(0, 120),
      ok: i.complete && i.naturalWidth > 0}));
  const links = Array.from(document.querySelectorAll('a[href]')).map(a => ({
      href: a.getAttribute('href'), url: a.href}));
  const ids = Array.from(document.querySelectorAll('[id],[name]'))
      .map(e => e.id || e.getAttribute('name'));
  return {images, links, ids, title: document.title};
})()"""


def find_browser() -> str | None:
    override = os.environ.get("CHROMIUM")
    if override:
        return override if shutil.which(override) else None
    return next((found for name in BROWSERS if (found := shutil.which(name))), None)


class Browser:
    """A headless Chromium spoken to over the DevTools pipe."""

    def __init__(self, executable: str) -> None:
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        self._profile = tempfile.mkdtemp(prefix="repro-chromium-")

        def child_fds() -> None:  # the pipe ends become fds 3 and 4, as Chromium expects
            reads, writes = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
                             for fd in (to_browser_r, from_browser_w))
            os.dup2(reads, 3)
            os.dup2(writes, 4)

        arguments = [executable, "--headless", "--remote-debugging-pipe", "--disable-gpu",
                     "--no-first-run", "--allow-file-access-from-files",
                     f"--user-data-dir={self._profile}", "about:blank"]
        if os.geteuid() == 0:
            arguments.insert(1, "--no-sandbox")  # Chromium refuses to sandbox as root
        self.process = subprocess.Popen(arguments, preexec_fn=child_fds, pass_fds=(3, 4),
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._buffer = b""
        self._next_id = 0
        self._events: list[dict] = []

    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> int:
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        return self._next_id

    def _receive(self, timeout_s: float) -> dict:
        deadline = time.monotonic() + timeout_s
        while b"\0" not in self._buffer:
            if time.monotonic() > deadline:
                raise TimeoutError("Chromium did not answer in time")
            chunk = os.read(self._from_browser, 1 << 16)
            if not chunk:
                raise RuntimeError("Chromium closed the DevTools pipe")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, params: dict | None = None, session: str | None = None,
             timeout_s: float = 30) -> dict:
        wanted = self._send(method, params, session)
        while True:
            message = self._receive(timeout_s)
            if message.get("id") == wanted:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            self._events.append(message)

    def wait_event(self, method: str, session: str, timeout_s: float = 30) -> None:
        deadline = time.monotonic() + timeout_s
        while True:
            for event in self._events:
                if event.get("method") == method and event.get("sessionId") == session:
                    self._events.remove(event)
                    return
            self._events.append(self._receive(max(deadline - time.monotonic(), 0.1)))

    def inspect(self, url: str) -> dict:
        """Load ``url`` in a new tab and return the page's images, links and ids."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget",
                            {"targetId": target, "flatten": True})["sessionId"]
        try:
            self.call("Page.enable", session=session)
            self.call("Page.navigate", {"url": url}, session=session)
            self.wait_event("Page.loadEventFired", session)
            result = self.call("Runtime.evaluate", {"expression": PAGE_SCRIPT,
                                                    "returnByValue": True}, session=session)
            return result["result"]["value"]
        finally:
            self.call("Target.closeTarget", {"targetId": target})

    def close(self) -> None:
        self.process.kill()
        self.process.wait()
        for fd in (self._to_browser, self._from_browser):
            os.close(fd)
        shutil.rmtree(self._profile, ignore_errors=True)


def markdown_page(markdown: Path) -> Path:
    """A temporary HTML page showing ``markdown``'s images and links, relative to its folder."""
    text = markdown.read_text(encoding="utf-8")
    parts = [f"<!doctype html><meta charset='utf-8'><base href='{markdown.parent.as_uri()}/'>"
             f"<title>{html.escape(markdown.name)}</title>"]
    for alt, target in re.findall(r"!\[([^\]]*)\]\(([^)\s]+)\)", text):
        parts.append(f"<img alt='{html.escape(alt)}' src='{html.escape(target)}'>")
    for label, target in re.findall(r"(?<!!)\[([^\]]+)\]\(([^)\s]+)\)", text):
        parts.append(f"<a href='{html.escape(target)}'>{html.escape(label)}</a>")
    handle, name = tempfile.mkstemp(suffix=".html", prefix=f"{markdown.stem}-")
    with os.fdopen(handle, "w", encoding="utf-8") as page:
        page.write("\n".join(parts))
    return Path(name)


def page_problems(page: Path, found: dict, shown_as: Path) -> tuple[list[str], list[str]]:
    """(problems, external links) of one inspected page."""
    problems = [f"{shown_as}: image {image['src']!r} did not load"
                for image in found["images"] if not image["ok"]]
    external = []
    for link in found["links"]:
        href, url = link["href"], urlparse(link["url"])
        if href.startswith("#"):
            fragment = href[1:]  # a browser tries the fragment as written, then decoded
            if fragment and fragment not in found["ids"] and unquote(fragment) not in found[
                    "ids"]:
                problems.append(f"{shown_as}: in-page link {href!r} names no element")
        elif url.scheme == "file":
            if not Path(unquote(url.path)).exists():
                problems.append(f"{shown_as}: link {href!r} points at a missing file")
        elif url.scheme in ("http", "https"):
            external.append(link["url"])
        elif url.scheme not in ("mailto", "data", "javascript"):
            problems.append(f"{shown_as}: link {href!r} has an unexpected scheme")
    return problems, external


def pages_below(targets: list[Path]) -> list[Path]:
    pages: list[Path] = []
    for target in targets:
        if target.is_file():
            pages.append(target.resolve())
        elif target.is_dir():
            pages += sorted(target.resolve().rglob("*.html"))
            pages += sorted(target.resolve().rglob("REPORT.md"))
    return pages


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("targets", nargs="*", type=Path,
                        default=[REPO / "results", REPO / "build" / "report"])
    parser.add_argument("--require-chromium", action="store_true",
                        help="exit 2 instead of 0 when Chromium is missing")
    args = parser.parse_args(argv)
    executable = find_browser()
    if executable is None:
        print("SKIPPED: Chromium is not installed, so nothing was checked. Install Debian's "
              "package (apt-get install chromium) or set CHROMIUM=/path/to/chromium.")
        return 2 if args.require_chromium else 0
    pages = pages_below(args.targets)
    if not pages:
        print(f"error: no HTML page or REPORT.md below {', '.join(map(str, args.targets))}")
        return 1
    browser = Browser(executable)
    problems: list[str] = []
    external: set[str] = set()
    try:
        for page in pages:
            shown = markdown_page(page) if page.suffix == ".md" else page
            try:
                found = browser.inspect(shown.resolve().as_uri())
            finally:
                if shown != page:
                    shown.unlink()
            page_issues, links = page_problems(page, found, page)
            problems += page_issues
            external.update(links)
            print(f"{'ok  ' if not page_issues else 'FAIL'} {page}: {len(found['images'])} "
                  f"image(s), {len(found['links'])} link(s)"
                  + ("  (warning: no figure on this page)" if not found["images"] else ""))
    finally:
        browser.close()
    if external:
        print(f"{len(external)} link(s) to other sites listed, not followed:")
        print("\n".join(f"  {url}" for url in sorted(external)))
    for problem in problems:
        print(f"problem: {problem}")
    print(f"{len(pages)} page(s) checked in {executable}: "
          f"{'no problem' if not problems else f'{len(problems)} problem(s)'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
