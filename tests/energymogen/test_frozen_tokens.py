"""The pipeline encodes a caption set once per process with the frozen encoder (the encoder
keeps its last batches by content, ``FrozenTextEncoder.tokens``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.energymogen.pipeline import _caption_rows
from repro.energymogen.settings import pipeline_config
from repro.models.frozen_text import shared_minilm

CAPTIONS = [["a person walks forward and then turns left", "someone waves with the right hand"],
            ["a man jumps in place"]]


def test_frozen_tokens_are_computed_once_and_equal_the_encoder_s(
        monkeypatch: pytest.MonkeyPatch) -> None:
    encoder = shared_minilm("cpu")
    config = pipeline_config("quick")
    latents = torch.zeros(2, 1, 1)
    flat = [c for caps in CAPTIONS for c in caps]
    ids, lengths = encoder.tokenizer.encode_batch(flat, config.max_text_len)
    direct, direct_mask = encoder._tokens(torch.from_numpy(ids), torch.as_tensor(lengths))
    width = int(direct_mask.sum(1).max())
    first = _caption_rows(latents, CAPTIONS, encoder, encoder.tokenizer, config)
    assert torch.equal(first.tokens, direct[:, :width]) and torch.equal(first.mask,
                                                                         direct_mask[:, :width])

    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("encoded again")

    monkeypatch.setattr(type(encoder), "_tokens", fail)
    again = _caption_rows(latents, CAPTIONS, encoder, encoder.tokenizer, config)
    assert torch.equal(again.tokens, first.tokens) and torch.equal(again.mask, first.mask)
    again.tokens.zero_()  # a caller's in-place change never reaches the memo
    assert torch.equal(_caption_rows(latents, CAPTIONS, encoder, encoder.tokenizer,
                                     config).tokens, first.tokens)
    with pytest.raises(AssertionError, match="encoded again"):
        _caption_rows(latents[:1], CAPTIONS[:1], encoder, encoder.tokenizer, config)
    assert np.array_equal(first.latents.numpy(), latents[[0, 0, 1]].numpy())
