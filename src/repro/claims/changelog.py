"""The registry changelog read per claim: why a verdict may differ from version 1's.

``docs/REGISTRY_CHANGELOG.md`` has one ``## Version N`` section per version; inside it,
``### GMD-A3, GMD-A4, GMD-F1 (…)`` subsections whose heading names claims, a ``### Per claim``
subsection whose bullets start with the claims in bold (``**GMD-A1, A2, B1**``: a short ID
keeps the paper prefix of the one before it), and ``### For every claim`` (rules of every
claim). :func:`claim_changes` gives, per claim ID, the bullets that concern it with the
version and the anchor of their subsection, so the report cites the changelog rather than
restating it.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from repro.infra import paths

_VERSION = re.compile(r"^## Version (\d+)\b")
_FULL_ID = re.compile(r"\b(GMD|EMG)-([A-F]?\d)\b")
_LIST_ID = re.compile(r"\b(?:(GMD|EMG)-)?([A-F]\d|\d)\b")
_BOLD_LEAD = re.compile(r"^\*\*(?P<ids>[^*]+)\*\*")
EVERY_CLAIM = "*"  # the key of the bullets that concern every claim


@dataclass(frozen=True)
class Change:
    """One changelog bullet as it concerns a claim."""

    version: int
    section: str
    anchor: str
    text: str


def github_anchor(heading: str, seen: dict[str, int]) -> str:
    """GitHub's anchor for a Markdown heading (lower case, punctuation dropped, spaces as
    hyphens, ``-1``, ``-2`` … for repeats); ``seen`` counts the anchors of the file so far."""
    slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
    count = seen.get(slug, 0)
    seen[slug] = count + 1
    return slug if count == 0 else f"{slug}-{count}"


def ids_in(text: str) -> list[str]:
    """Claim IDs of a heading or bold lead: ``GMD-A1, A2`` → GMD-A1, GMD-A2; ``EMG-2, EMG-3``."""
    if not _FULL_ID.search(text):
        return []
    ids, prefix = [], ""
    for match in _LIST_ID.finditer(text):
        prefix = match[1] or prefix
        if prefix and (prefix == "EMG") == match[2].isdigit():
            ids.append(f"{prefix}-{match[2]}")
    return list(dict.fromkeys(ids))


def _bullets(lines: Iterable[str]) -> list[str]:
    bullets: list[str] = []
    for line in lines:
        if line.startswith("- "):
            bullets.append(line[2:].strip())
        elif line.startswith("  ") and bullets and line.strip():
            bullets[-1] += " " + line.strip()
    return bullets


def parse_changelog(text: str) -> dict[str, list[Change]]:
    """Claim ID (or :data:`EVERY_CLAIM`) → its changes, newest version first."""
    seen: dict[str, int] = {}
    sections: list[tuple[int, str, str, list[str]]] = []  # version, heading, anchor, lines
    version = 0
    for line in text.splitlines():
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
            anchor = github_anchor(heading, seen)
            found = _VERSION.match(line)
            if found:
                version = int(found[1])
            if line.startswith("### ") and version:
                sections.append((version, heading, anchor, []))
            continue
        if sections and sections[-1][0] == version:
            sections[-1][3].append(line)
    changes: dict[str, list[Change]] = {}
    for version, heading, anchor, lines in sections:
        heading_ids = ids_in(heading)
        every = heading.lower().startswith("for every claim")
        for bullet in _bullets(lines):
            lead = _BOLD_LEAD.match(bullet)
            targets = (heading_ids or ([EVERY_CLAIM] if every else [])
                       or (ids_in(lead["ids"]) if lead else []))
            for claim_id in targets:
                changes.setdefault(claim_id, []).append(Change(version, heading, anchor,
                                                               bullet))
    for claim_changes_ in changes.values():
        claim_changes_.sort(key=lambda c: -c.version)
    return changes


def changelog_path() -> Path:
    return paths.REPO_ROOT / "docs" / "REGISTRY_CHANGELOG.md"


def claim_changes(path: str | os.PathLike | None = None) -> dict[str, list[Change]]:
    """:func:`parse_changelog` of ``docs/REGISTRY_CHANGELOG.md`` (or ``path``); {} when the
    file is missing (the report's changes then cite no reason, and say so)."""
    source = Path(path or changelog_path())
    if not source.is_file():
        return {}
    return parse_changelog(source.read_text(encoding="utf-8"))
