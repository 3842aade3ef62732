"""The stand-in text side: tokenizer, vocabulary and a tiny sentence/token encoder.

The papers use GloVe + a GRU (Guo et al.'s evaluator), CLIP (MLD/EnergyMoGen's denoiser) or
DistilBERT (TMR). The stand-in captions use a small closed vocabulary, so a learned word
embedding and a bidirectional GRU (as Guo's text encoder, minus the POS one-hots) suffice.
"""

from __future__ import annotations

import os
import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from repro.infra.storage import read_json, write_json

PAD, UNK = "<pad>", "<unk>"
PAD_ID, UNK_ID = 0, 1
_WORD = re.compile(r"[a-z0-9]+")


def tokenize(caption: str) -> list[str]:
    """Lower-case words; punctuation and apostrophes split or drop ("person's" → person, s)."""
    if not isinstance(caption, str):
        raise ValueError(f"caption must be a str, got {type(caption).__name__}")
    return _WORD.findall(caption.lower())


@dataclass(frozen=True)
class Vocabulary:
    """Token list with ``<pad>`` = 0 and ``<unk>`` = 1, then words by count, ties by spelling."""

    tokens: tuple[str, ...]

    def __post_init__(self) -> None:
        if self.tokens[:2] != (PAD, UNK):
            raise ValueError(f"a vocabulary starts with {PAD!r}, {UNK!r}; got {self.tokens[:2]}")
        if len(set(self.tokens)) != len(self.tokens):
            raise ValueError("vocabulary tokens must be unique")
        object.__setattr__(self, "_index", {t: i for i, t in enumerate(self.tokens)})

    @classmethod
    def build(cls, captions: Iterable[str], min_count: int = 1) -> Vocabulary:
        """Every word seen at least ``min_count`` times in ``captions``."""
        if min_count < 1:
            raise ValueError(f"min_count must be ≥ 1, got {min_count}")
        counts = Counter(word for caption in captions for word in tokenize(caption))
        kept = sorted((w for w, c in counts.items() if c >= min_count),
                      key=lambda w: (-counts[w], w))
        return cls((PAD, UNK, *kept))

    def __len__(self) -> int:
        return len(self.tokens)

    def __contains__(self, word: object) -> bool:
        return word in self._index

    def id(self, word: str) -> int:
        return self._index.get(word, UNK_ID)

    def encode(self, caption: str, max_len: int) -> tuple[np.ndarray, int]:
        """(ids (max_len,) int64 padded with 0, length): words beyond ``max_len`` are cut."""
        if max_len < 1:
            raise ValueError(f"max_len must be ≥ 1, got {max_len}")
        words = tokenize(caption)[:max_len]
        ids = np.full(max_len, PAD_ID, dtype=np.int64)
        ids[:len(words)] = [self.id(w) for w in words]
        return ids, len(words)

    def encode_batch(self, captions: Sequence[str],
                     max_len: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(ids (B, L), lengths (B,)); L = ``max_len`` or the longest caption (at least 1)."""
        if isinstance(captions, str):
            raise ValueError("encode_batch takes a sequence of captions, not one str")
        if max_len is None:
            max_len = max([1, *(len(tokenize(c)) for c in captions)])
        encoded = [self.encode(c, max_len) for c in captions]
        ids = np.stack([e[0] for e in encoded]) if encoded else np.zeros((0, max_len), np.int64)
        return ids, np.array([e[1] for e in encoded], dtype=np.int64)

    def decode(self, ids: Sequence[int]) -> list[str]:
        return [self.tokens[i] for i in ids if i != PAD_ID]

    def save(self, path: str | os.PathLike) -> None:
        write_json(path, {"tokens": list(self.tokens)})

    @classmethod
    def load(cls, path: str | os.PathLike) -> Vocabulary:
        return cls(tuple(read_json(path)["tokens"]))


class TextEncoder(nn.Module):
    """Word embedding → bidirectional GRU → per-token features (B, L, D) and a sentence
    vector (B, D) = Linear(masked mean of the token features).

    Captions of length 0 are read as a single ``<pad>`` token (a learned "empty" vector).
    """

    def __init__(self, vocab_size: int, dim: int = 64, word_dim: int = 64) -> None:
        super().__init__()
        if dim % 2:
            raise ValueError(f"dim must be even (two GRU directions), got {dim}")
        self.dim = dim
        self.embedding = nn.Embedding(vocab_size, word_dim)
        self.gru = nn.GRU(word_dim, dim // 2, batch_first=True, bidirectional=True)
        self.sentence = nn.Linear(dim, dim)

    def tokens(self, ids: torch.Tensor,
               lengths: torch.Tensor | Sequence[int]) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-token features (B, L, D) (zero at padding) and mask (B, L), True = a token."""
        if ids.ndim != 2:
            raise ValueError(f"ids must be (B, L), got {tuple(ids.shape)}")
        lengths = torch.as_tensor(lengths, dtype=torch.long).cpu().clamp(min=1)
        if ids.shape[0] == 0:
            raise ValueError("empty batch of captions")
        if lengths.shape != (ids.shape[0],) or int(lengths.max()) > ids.shape[1]:
            raise ValueError(f"lengths must be B={ids.shape[0]} values ≤ L={ids.shape[1]}")
        packed = nn.utils.rnn.pack_padded_sequence(
            self.embedding(ids), lengths, batch_first=True, enforce_sorted=False)
        out, _ = self.gru(packed)
        out, _ = nn.utils.rnn.pad_packed_sequence(out, batch_first=True,
                                                  total_length=ids.shape[1])
        mask = torch.arange(ids.shape[1], device=ids.device)[None] < lengths.to(ids.device)[:, None]
        return out, mask

    def forward(self, ids: torch.Tensor, lengths: torch.Tensor | Sequence[int]) -> torch.Tensor:
        """Sentence vectors (B, D)."""
        out, mask = self.tokens(ids, lengths)
        pooled = out.sum(1) / mask.sum(1, keepdim=True)
        return self.sentence(pooled)
