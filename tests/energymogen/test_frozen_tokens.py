"""The pipeline encodes a caption set once per process with the frozen encoder."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.energymogen.text_stage import frozen_caption_tokens
from repro.models.frozen_text import shared_minilm

CAPTIONS = ["a person walks forward and then turns left", "someone waves with the right hand",
            "a man jumps in place"]


def test_frozen_tokens_are_computed_once_and_equal_the_encoder_s(
        monkeypatch: pytest.MonkeyPatch) -> None:
    encoder = shared_minilm("cpu")
    ids, lengths = encoder.tokenizer.encode_batch(CAPTIONS, 77)
    lengths = np.asarray(lengths)
    direct, direct_mask = encoder.tokens(torch.from_numpy(ids), lengths)
    width = int(direct_mask.sum(1).max())
    first = frozen_caption_tokens(encoder, ids, lengths)
    assert torch.equal(first[0], direct[:, :width]) and torch.equal(first[1],
                                                                     direct_mask[:, :width])

    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("encoded again")

    monkeypatch.setattr(type(encoder), "tokens", fail)
    again = frozen_caption_tokens(encoder, ids, lengths)
    assert torch.equal(again[0], first[0]) and torch.equal(again[1], first[1])
    again[0].zero_()  # a caller's in-place change never reaches the memo
    assert torch.equal(frozen_caption_tokens(encoder, ids, lengths)[0], first[0])
    other_ids, other_lengths = encoder.tokenizer.encode_batch(CAPTIONS[:2], 77)
    with pytest.raises(AssertionError, match="encoded again"):
        frozen_caption_tokens(encoder, other_ids, np.asarray(other_lengths))
