#!/usr/bin/env python3
r"""Open the rendered results in a real headless browser and check what a reader would see.

    python scripts/check_rendered.py [FOLDER_OR_FILE ...]     (default: results/ and
                                                               build/report/)

Every ``*.html`` page below the folders (the executed notebooks, the report's index.html) and
every ``REPORT.md`` (shown through a minimal HTML page with its images, links and anchors) is
loaded in headless Chromium, Debian's ``chromium`` package (``apt-get install chromium``), with
the network cut off (every host name resolves to nothing, every request goes to a closed local
proxy, and DevTools emulates an offline browser): the results must read offline. A page passes
when every image has loaded (``complete`` and a natural width above 0), every link to a file
points at one that exists, every in-page anchor (``#id``) names an element of the page, it
asked the network for nothing (a script, style sheet or image from another site), and its
equations are typeset: no raw TeX left in its text outside code (``$…$`` as pandoc reads it,
``$$``, ``\(…\)``, ``\[…\]``, ``\begin{…}``) and every MathML ``<math>`` element laid out
as math with no TeX command left inside. Links to other sites are listed, not followed.

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
#: the cut-off network: no name resolves, and anything that still tries goes to a closed port
OFFLINE_FLAGS = ("--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
                 "--proxy-bypass-list=<-loopback>")
#: elements whose text is code or typeset math, not prose
NOT_PROSE = "code, pre, kbd, samp, script, style, textarea, math, .MathJax, mjx-container"
PAGE_SCRIPT = """(async () => {
  await document.fonts.ready;
  const images = Array.from(document.images).map(i => ({
      src: (i.getAttribute('src') || '').slice(0, 120),
      ok: i.complete && i.naturalWidth > 0}));
  const links = Array.from(document.querySelectorAll('a[href]')).map(a => ({
      href: a.getAttribute('href'), url: a.href}));
  const ids = Array.from(document.querySelectorAll('[id],[name]'))
      .map(e => e.id || e.getAttribute('name'));
  const prose = document.body ? document.body.cloneNode(true) : null;
  if (prose) prose.querySelectorAll('NOT_PROSE').forEach(e => e.remove());
  const math = Array.from(document.querySelectorAll('math')).map(m => {
      const box = m.getBoundingClientRect();
      return {text: m.textContent.slice(0, 120), display: getComputedStyle(m).display,
              width: box.width, height: box.height};});
  const errors = Array.from(document.querySelectorAll('merror, .MathJax_Error, mjx-merror'))
      .map(e => e.textContent.slice(0, 120));
  return {images, links, ids, title: document.title, math, math_errors: errors,
          text: prose ? prose.textContent : ''};
})()""".replace("NOT_PROSE", NOT_PROSE)
#: raw TeX in a page's prose: what a Markdown renderer with math would have typeset
RAW_TEX = re.compile(
    r"\$\$.+?\$\$"  # $$display$$
    r"|(?<![$\\\w])\$(?=[^\s$])[^$]{1,400}?(?<![\s\\$])\$(?!\d)"  # $inline$, pandoc's rule
    r"|\\\(.+?\\\)|\\\[.+?\\\]"  # \(inline\), \[display\]
    r"|\\begin\{[a-z]+\*?\}", re.S)  # \begin{equation}
#: a TeX command left inside a math element (a macro the converter did not know)
TEX_COMMAND = re.compile(r"\\[A-Za-z]+")


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
                     "--no-first-run", "--allow-file-access-from-files", *OFFLINE_FLAGS,
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
        """Load ``url`` offline in a new tab and return the page's images, links, ids, math,
        prose text and the URLs it asked the network for (``requests``)."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget",
                            {"targetId": target, "flatten": True})["sessionId"]
        try:
            self.call("Page.enable", session=session)
            self.call("Network.enable", session=session)
            self.call("Network.emulateNetworkConditions",
                      {"offline": True, "latency": 0, "downloadThroughput": -1,
                       "uploadThroughput": -1}, session=session)
            self.call("Page.navigate", {"url": url}, session=session)
            self.wait_event("Page.loadEventFired", session)
            result = self.call("Runtime.evaluate", {"expression": PAGE_SCRIPT,
                                                    "returnByValue": True,
                                                    "awaitPromise": True}, session=session)
            found = result["result"]["value"]
            found["requests"] = sorted({
                event["params"]["request"]["url"] for event in self._events
                if event.get("sessionId") == session
                and event.get("method") == "Network.requestWillBeSent"
                and urlparse(event["params"]["request"]["url"]).scheme in ("http", "https")})
            return found
        finally:
            self._events = [e for e in self._events if e.get("sessionId") != session]
            self.call("Target.closeTarget", {"targetId": target})

    def close(self) -> None:
        self.process.kill()
        self.process.wait()
        for fd in (self._to_browser, self._from_browser):
            os.close(fd)
        shutil.rmtree(self._profile, ignore_errors=True)


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a Markdown heading: lower case, punctuation dropped, spaces as
    ``-``."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def markdown_page(markdown: Path) -> Path:
    """A temporary HTML page showing ``markdown``'s images and links, relative to its folder,
    and its anchors: each heading's as GitHub makes it, and ``<a id=…>`` written in it."""
    text = markdown.read_text(encoding="utf-8")
    parts = [f"<!doctype html><meta charset='utf-8'><base href='{markdown.parent.as_uri()}/'>"
             f"<title>{html.escape(markdown.name)}</title>"]
    seen: dict[str, int] = {}
    for heading in re.findall(r"^#{1,6} +(.+?) *#* *$", text, re.M):
        anchor = github_anchor(heading)
        count = seen.get(anchor, 0)
        seen[anchor] = count + 1
        parts.append(f"<span id='{html.escape(f'{anchor}-{count}' if count else anchor)}'>"
                     "</span>")
    for anchor in re.findall(r"<a (?:id|name)=[\"']([^\"']+)[\"']", text):
        parts.append(f"<span id='{html.escape(anchor)}'></span>")
    for alt, target in re.findall(r"!\[([^\]]*)\]\(([^)\s]+)\)", text):
        parts.append(f"<img alt='{html.escape(alt)}' src='{html.escape(target)}'>")
    for label, target in re.findall(r"(?<!!)\[([^\]]+)\]\(([^)\s]+)\)", text):
        parts.append(f"<a href='{html.escape(target)}'>{html.escape(label)}</a>")
    handle, name = tempfile.mkstemp(suffix=".html", prefix=f"{markdown.stem}-")
    with os.fdopen(handle, "w", encoding="utf-8") as page:
        page.write("\n".join(parts))
    return Path(name)


def math_problems(found: dict, shown_as: Path) -> list[str]:
    """Raw TeX in the page's prose, math elements not laid out as math or holding a TeX
    command, math errors."""
    problems = []
    for match in list(RAW_TEX.finditer(found.get("text", "")))[:3]:
        problems.append(f"{shown_as}: raw TeX in the text, not typeset: "
                        f"{' '.join(match.group(0).split())[:80]!r}")
    for element in found.get("math", []):
        if not element["display"].endswith("math") or not (element["width"] > 0
                                                             and element["height"] > 0):
            problems.append(f"{shown_as}: math element not laid out as math "
                            f"(display {element['display']!r}): {element['text'][:60]!r}")
        elif TEX_COMMAND.search(element["text"]):
            problems.append(f"{shown_as}: math element still holds a TeX command: "
                            f"{element['text'][:60]!r}")
    problems += [f"{shown_as}: math error: {text[:60]!r}" for text in found.get("math_errors",
                                                                               [])]
    return problems


def page_problems(page: Path, found: dict, shown_as: Path) -> tuple[list[str], list[str]]:
    """(problems, external links) of one inspected page."""
    problems = [f"{shown_as}: image {image['src']!r} did not load"
                for image in found["images"] if not image["ok"]]
    problems += [f"{shown_as}: asks the network for {url[:100]} (the page must read offline)"
                 for url in found.get("requests", [])]
    if page.suffix != ".md":   # a Markdown file's math is its viewer's to typeset
        problems += math_problems(found, shown_as)
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
                  f"image(s), {len(found['links'])} link(s), {len(found['math'])} formula(s)"
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
