"""The papers' errata: ``docs/ERRATA.md`` parsed into entries and rendered into the report.

Each entry is a ``## title`` section with the fields ``Paper``, ``Printed``, ``Correction``
or ``Open question``, ``Status`` and ``Shown by`` (claim IDs and ``tests/…::test_name``), each
a ``- **Field:** text`` bullet. The report repeats the file's entries; a test checks that
every claim and test an entry names exists.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from repro.infra import paths

FIELDS = ("Paper", "Printed", "Numbers", "Inconsistency", "Correction", "Open question",
          "Claim impact", "Status", "Shown by")
REQUIRED = ("Paper", "Printed", "Claim impact", "Status", "Shown by")
STATUSES = ("corrected", "open question")
_FIELD = re.compile(r"^- \*\*(?P<name>[^*]+?):\*\*\s*(?P<text>.*)$")
_CLAIM_ID = re.compile(r"\b(?:GMD-[A-F]\d|EMG-\d)\b")
_TEST = re.compile(r"`(?P<path>tests/[\w/]+\.py)::(?P<name>\w+)`")


@dataclass(frozen=True)
class Erratum:
    """One discrepancy: where, what is printed, the correction or open question, who shows it."""

    title: str
    fields: dict[str, str]

    @property
    def status(self) -> str:
        return self.fields.get("Status", "")

    @property
    def is_open(self) -> bool:
        return self.status.startswith("open question")

    @property
    def claim_ids(self) -> list[str]:
        """The claims the entry names as showing it or as affected by it."""
        named = self.fields.get("Shown by", "") + " " + self.fields.get("Claim impact", "")
        return list(dict.fromkeys(_CLAIM_ID.findall(named)))

    @property
    def tests(self) -> list[tuple[str, str]]:
        """(path, test name) of every test the entry names."""
        return [(m["path"], m["name"]) for m in _TEST.finditer(self.fields.get("Shown by", ""))]

    @property
    def resolution(self) -> str:
        """The correction, else the open question."""
        return self.fields.get("Correction") or self.fields.get("Open question", "")


def errata_path() -> Path:
    return paths.REPO_ROOT / "docs" / "ERRATA.md"


def parse_errata(text: str) -> list[Erratum]:
    """The entries of an ERRATA.md text (up to the first level-1 heading after an entry);
    raises ValueError naming an entry with a missing or unknown field, or an unknown status."""
    entries: list[Erratum] = []
    title: str | None = None
    fields: dict[str, str] = {}
    current: str | None = None

    def close() -> None:
        if title is None:
            return
        missing = [f for f in REQUIRED if f not in fields]
        if not ("Correction" in fields or "Open question" in fields):
            missing.append("Correction or Open question")
        if missing:
            raise ValueError(f"erratum {title!r}: missing {', '.join(missing)}")
        if not fields["Status"].startswith(STATUSES):
            raise ValueError(f"erratum {title!r}: status must start with one of {STATUSES}, "
                             f"got {fields['Status']!r}")
        entries.append(Erratum(title, dict(fields)))

    for line in text.splitlines():
        if line.startswith("# ") and (title is not None or entries):
            break
        if line.startswith("## "):
            close()
            title, fields, current = line[3:].strip(), {}, None
            continue
        if title is None:
            continue
        match = _FIELD.match(line)
        if match:
            current = match["name"].strip()
            if current not in FIELDS:
                raise ValueError(f"erratum {title!r}: unknown field {current!r} (fields: "
                                 f"{', '.join(FIELDS)})")
            fields[current] = match["text"].strip()
        elif line.startswith("  ") and current is not None and line.strip():
            fields[current] += " " + line.strip()
        elif line.strip():
            current = None
    close()
    return entries


def load_errata(path: str | os.PathLike | None = None) -> list[Erratum] | None:
    """The entries of ``docs/ERRATA.md`` (or ``path``); None when the file is missing (a
    checkout without docs/: the report then says so)."""
    source = Path(path or errata_path())
    if not source.is_file():
        return None
    return parse_errata(source.read_text(encoding="utf-8"))


def _sentence(text: str) -> str:
    return text if text.endswith((".", "?")) else text + "."


def errata_markdown(entries: list[Erratum] | None, docs: str = "../docs") -> list[str]:
    """The report's "Paper errata" section: one short paragraph per entry; ``docs``: the
    link from the report's folder to the repository's docs/."""
    if entries is None:
        return ["", "## Paper errata", "", f"{errata_path()} is missing: no errata listed.", ""]
    lines = ["", "## Paper errata", "",
             f"{len(entries)} discrepancies in the papers' printed text "
             f"({sum(e.is_open for e in entries)} of them open questions); the source is "
             f"[docs/ERRATA.md]({docs}/ERRATA.md), which also says, table by table and "
             "equation by equation, what the audit read and found consistent.", ""]
    for e in entries:
        head = "Open question" if e.is_open else "Correction"
        inconsistency = (f"*Inconsistency:* {_sentence(e.fields['Inconsistency'])} "
                         if "Inconsistency" in e.fields else "")
        lines += [f"- **{e.title}** ({e.fields['Paper']}). Printed: "
                  f"{_sentence(e.fields['Printed'])} {inconsistency}*{head}:* "
                  f"{_sentence(e.resolution)} *Claim impact:* "
                  f"{_sentence(e.fields['Claim impact'])} *Shown by:* {e.fields['Shown by']}"]
    return lines + [""]
