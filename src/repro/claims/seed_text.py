"""The papers' text (``../shared/seeds/``) read against ``claims.printed``: is each printed row
in its table's block of the seed, verbatim and whole, and is each quoted sentence there?

A row matches a line of its table's block when the line starts with the row's label and the
numbers after the label are exactly the row's numbers in order (intervals, ``\\textbf``/
``\\mathbf`` and ``$`` aside; every other number on the line counts, so a missing, extra or
changed cell fails); each cell's interval and bold must be as printed. A table is whole when
every data line of its block is some row's line. Quotes are compared after the text's
Markdown links (``[\\[69\\]](#page-10-9)`` → ``[69]``), accents, line-end hyphenation and
whitespace are normalised.
"""

from __future__ import annotations

import re
import unicodedata
from functools import cache
from pathlib import Path

from repro.claims.printed import QUOTES, SEEDS, TABLES, Quote, Row, Table
from repro.infra import paths

__all__ = ["SeedTextMissing", "all_problems", "normalise", "quote_problems", "row_problems",
           "seed_text", "seeds_dir", "table_block", "table_problems"]

_LINK = re.compile(r"\[((?:\\.|[^\]\\])*)\]\(#[^)]*\)")
_INTERVAL = re.compile(r"\^\{\\pm\s*([^}]*)\}")
_BOLD = re.compile(r"\\(?:textbf|mathbf)\{([^}]*)\}")
_NUMBER = re.compile(r"\d+(?:\.\d+)?")
_HEADER_WORDS = ("Top-", "uparrow", "downarrow", "rightarrow")


class SeedTextMissing(FileNotFoundError):
    """The papers' text is not beside the clone: it lives in ``../shared/seeds/`` (or
    ``$REPRO_SHARED_DIR/seeds``), which the package does not ship; the printed tables it
    needs are its own (``claims.printed``)."""


def seeds_dir() -> Path:
    """Where the papers' text is read from."""
    return paths.shared_dir() / "seeds"


@cache
def seed_text(paper: str) -> str:
    """The seed file of ``paper`` ("GMD" or "EnergyMoGen"), as stored."""
    path = seeds_dir() / SEEDS[paper]
    if not path.is_file():
        raise SeedTextMissing(f"{paper}'s text not found at {path}: the papers' text is read "
                              "from ../shared/seeds (or $REPRO_SHARED_DIR/seeds), which a "
                              "clone does not carry")
    return path.read_text(encoding="utf-8")


def normalise(text: str) -> str:
    """Unicode NFC (the seeds spell some accents as combining marks), links to their text,
    escaped brackets and parentheses unescaped, line-end hyphens joined, whitespace runs to
    one space."""
    text = _LINK.sub(r"\1", unicodedata.normalize("NFC", text))
    text = re.sub(r"\\([\[\]()])", r"\1", text)
    text = re.sub(r"(\w)-[ \t]*\n\s*(\w)", r"\1\2", text)
    return re.sub(r"\s+", " ", text).strip()


def table_block(table: Table, text: str) -> str:
    """The seed's text from the table's ``start`` to its next ``end``."""
    start = text.find(table.start)
    if start < 0:
        raise ValueError(f"{table.paper} {table.name}: start {table.start!r} not in the seed")
    end = text.find(table.end, start + len(table.start))
    if end < 0:
        raise ValueError(f"{table.paper} {table.name}: end {table.end!r} not after its start")
    return text[start:end]


def _numbers(text: str) -> list[str]:
    return _NUMBER.findall(_BOLD.sub(r"\1", _INTERVAL.sub("", text)))


def _line_body(line: str, label: str) -> str | None:
    """What follows ``label`` on ``line`` (a leading ``$`` ignored), or None."""
    stripped = line.strip().lstrip("$")
    return stripped[len(label):] if stripped.startswith(label) else None


def _row_numbers(row: Row) -> list[str]:
    """The number tokens of the row's printed values, in order."""
    return [n for i, cell in enumerate(row.cells) if cell for n in _numbers(row.parsed(i)[0])]


def _is_row_line(row: Row, line: str) -> bool:
    body = _line_body(line, row.label)
    if body is None:
        return False
    tokens = _numbers(body)
    numbers = _row_numbers(row)
    return (tokens[row.offset::row.stride] == numbers
            and (row.stride > 1 or len(tokens) == len(numbers)))


def _row_matches(row: Row, body: str) -> list[str]:
    """Problems of ``row`` against a line body whose numbers are the row's."""
    problems = []
    cells = [row.parsed(i) for i in range(len(row.cells)) if row.cells[i]]
    for printed, interval, _ in cells:
        if interval is not None and not re.search(
                re.escape(printed) + r"\}?\^\{\\pm\s*" + re.escape(interval.strip()) + r"\}",
                body):
            problems.append(f"{printed}±{interval} not printed so")
    if row.stride == 1:
        if len(_INTERVAL.findall(body)) != sum(i is not None for _, i, _ in cells):
            problems.append("the line prints intervals the row does not hold (or the reverse)")
        bold = sorted(_BOLD.findall(body))
        if bold != sorted(p for p, _, b in cells if b):
            problems.append(f"bold on the line {bold} is not the row's")
    return problems


def row_problems(table: Table, row: Row, text: str) -> list[str]:
    """Empty when exactly one line of the table's block is ``row`` as printed."""
    found = []
    for line in table_block(table, text).splitlines():
        if _is_row_line(row, line):
            found.append(_line_body(line, row.label) or "")
    name = f"{table.paper} {table.name} row {table.row_name(row)!r}"
    if len(found) != 1:
        return [f"{name}: {len(found)} lines of the block print it (want 1)"]
    return [f"{name}: {p}" for p in _row_matches(row, found[0])]


def table_problems(table: Table, text: str) -> list[str]:
    """Every row's problems, and every data line of the block that no row accounts for."""
    problems = [p for row in table.rows for p in row_problems(table, row, text)]
    block = table_block(table, text).splitlines()[1:]
    for line in block:
        if any(word in line for word in _HEADER_WORDS) or len(_numbers(line)) < 3:
            continue
        if not any(_is_row_line(row, line) for row in table.rows):
            problems.append(f"{table.paper} {table.name}: line {line.strip()!r} is no row's")
    return problems


def quote_problems(quote: Quote, text: str | None = None) -> list[str]:
    """Empty when the quote is in its paper's seed (normalised)."""
    source = normalise(seed_text(quote.paper) if text is None else text)
    return [] if normalise(quote.text) in source else [
        f"{quote.paper} {quote.where}: {quote.text[:60]!r}… is not in the seed"]


def all_problems() -> list[str]:
    """Every table and quote of ``claims.printed`` against the seeds."""
    problems = [p for t in TABLES.values() for p in table_problems(t, seed_text(t.paper))]
    return problems + [p for q in QUOTES.values() for p in quote_problems(q)]
