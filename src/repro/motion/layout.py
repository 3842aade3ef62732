"""HumanML3D's folder conventions that the loader and the usability check share: the splits,
the frame range a clip must have, and the ``texts/ID.txt`` and ``<split>.txt`` readers
(REFERENCE.md "Folder layout"; ``repro.motion.humanml3d`` re-exports all of them)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["MAX_FRAMES_EXCLUSIVE", "MIN_FRAMES", "SPLITS", "UNIT_LENGTH", "TextLine",
           "caption_spans", "kept_length", "parse_text_line", "read_split", "read_text_file"]

SPLITS = ("train", "val", "test")
MIN_FRAMES = 40
#: HumanML3D drops clips of 200 frames or more, whatever ``max_length`` is.
MAX_FRAMES_EXCLUSIVE = 200
UNIT_LENGTH = 4


def kept_length(frames: int, min_length: int = MIN_FRAMES) -> bool:
    """Whether the loader keeps a clip or captioned piece of ``frames`` frames:
    ``min_length ≤ T < MAX_FRAMES_EXCLUSIVE`` and at least one ``UNIT_LENGTH``."""
    return min_length <= frames < MAX_FRAMES_EXCLUSIVE and frames >= UNIT_LENGTH


# ------------------------------------------------------------------------------- text files

@dataclass(frozen=True)
class TextLine:
    """One line of ``texts/ID.txt``: ``caption#word/POS ...#start#end``."""

    caption: str
    tokens: tuple[str, ...]
    start: float
    end: float

    @property
    def whole_clip(self) -> bool:
        return self.start == 0.0 and self.end == 0.0


def parse_text_line(line: str) -> TextLine:
    """Parse one text line; NaN times count as 0 (HumanML3D). Raises ValueError naming the fault."""
    fields = line.rstrip("\r\n").split("#")
    if len(fields) != 4:
        raise ValueError(f"expected 4 '#'-separated fields (caption#tokens#start#end), "
                         f"got {len(fields)}")
    caption, token_field, start_field, end_field = fields
    if not caption.strip():
        raise ValueError("empty caption")
    tokens = tuple(token_field.split())
    bad = [token for token in tokens if "/" not in token]
    if bad:
        raise ValueError(f"tokens must be word/POS, got {bad[0]!r}")
    try:
        start, end = float(start_field), float(end_field)
    except ValueError as error:
        raise ValueError(f"start/end must be numbers, got {start_field!r}, "
                         f"{end_field!r}") from error
    start, end = (0.0 if math.isnan(t) else t for t in (start, end))
    if start < 0 or end < 0 or (end <= start and not (start == 0.0 and end == 0.0)):
        raise ValueError(f"bad time range {start}–{end} s")
    return TextLine(caption.strip(), tokens, start, end)


def caption_spans(lines: list[TextLine], fps: float
                  ) -> tuple[list[str], dict[tuple[int, int], list[str]]]:
    """The pieces the loader cuts from one clip's text lines: the captions of the whole clip
    (lines with start = end = 0), and the captions of each distinct frame span
    ``(int(start · fps), int(end · fps))``, in the order the spans first appear."""
    whole: list[str] = []
    spans: dict[tuple[int, int], list[str]] = {}
    for line in lines:
        if line.whole_clip:
            whole.append(line.caption)
        else:
            spans.setdefault((int(line.start * fps), int(line.end * fps)), []).append(line.caption)
    return whole, spans


def read_text_file(path: str | os.PathLike) -> list[TextLine]:
    """All non-blank lines of a text file; a bad line raises ValueError with path and line."""
    lines = []
    for number, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        try:
            lines.append(parse_text_line(line))
        except ValueError as error:
            raise ValueError(f"{path}, line {number}: {error}") from None
    return lines


def read_split(root: str | os.PathLike, split: str) -> list[str]:
    """The clip IDs listed in ``<root>/<split>.txt`` (one per line, blank lines ignored)."""
    path = Path(root) / f"{split}.txt"
    if not path.is_file():
        raise FileNotFoundError(f"split file {path} not found")
    return [line.strip() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
