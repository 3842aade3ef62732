"""Tokenizer, vocabulary and the tiny text encoder."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from repro.standin.text import PAD_ID, UNK_ID, TextEncoder, Vocabulary, tokenize

CAPTIONS = ["A person walks forward.", "a person jumps, then walks!", "Someone waves."]


def test_tokenize_lowercases_and_strips_punctuation():
    assert tokenize("A person walks, then JUMPS!") == ["a", "person", "walks", "then", "jumps"]
    assert tokenize("person's  arm-swing") == ["person", "s", "arm", "swing"]
    assert tokenize("...") == []
    with pytest.raises(ValueError, match="str"):
        tokenize(None)  # type: ignore[arg-type]


def test_vocabulary_order_and_min_count():
    vocab = Vocabulary.build(CAPTIONS)
    assert vocab.tokens[:2] == ("<pad>", "<unk>")
    # "a", "person", "walks" occur twice; ties broken alphabetically, then the singletons
    assert vocab.tokens[2:5] == ("a", "person", "walks")
    assert set(vocab.tokens[5:]) == {"forward", "jumps", "then", "someone", "waves"}
    frequent = Vocabulary.build(CAPTIONS, min_count=2)
    assert frequent.tokens == ("<pad>", "<unk>", "a", "person", "walks")
    with pytest.raises(ValueError, match="min_count"):
        Vocabulary.build(CAPTIONS, min_count=0)
    with pytest.raises(ValueError, match="starts with"):
        Vocabulary(("a", "b"))


def test_encode_pads_truncates_and_maps_unknown_words():
    vocab = Vocabulary.build(CAPTIONS, min_count=2)
    ids, length = vocab.encode("A person dances", max_len=5)
    assert length == 3
    np.testing.assert_array_equal(ids, [vocab.id("a"), vocab.id("person"), UNK_ID, PAD_ID, PAD_ID])
    ids, length = vocab.encode("a person walks a person walks", max_len=4)
    assert length == 4 and ids.tolist() == [2, 3, 4, 2]
    batch, lengths = vocab.encode_batch(["a person", "walks", ""])
    assert batch.shape == (3, 2) and lengths.tolist() == [2, 1, 0]
    assert vocab.decode(batch[0]) == ["a", "person"]
    with pytest.raises(ValueError, match="max_len"):
        vocab.encode("a", 0)


def test_vocabulary_save_load_roundtrip(tmp_path):
    vocab = Vocabulary.build(CAPTIONS)
    vocab.save(tmp_path / "vocab.json")
    assert Vocabulary.load(tmp_path / "vocab.json") == vocab


def _encoder(vocab: Vocabulary) -> TextEncoder:
    torch.manual_seed(0)
    return TextEncoder(len(vocab), dim=32, word_dim=16).eval()


def test_text_encoder_shapes_mask_and_padding_invariance():
    vocab = Vocabulary.build(CAPTIONS)
    encoder = _encoder(vocab)
    ids, lengths = vocab.encode_batch(CAPTIONS, max_len=6)
    tokens, mask = encoder.tokens(torch.from_numpy(ids), lengths)
    assert tokens.shape == (3, 6, 32) and mask.shape == (3, 6)
    assert mask.sum(1).tolist() == lengths.tolist()
    assert torch.all(tokens[~mask] == 0)
    short = encoder(torch.from_numpy(ids), lengths)
    long_ids, long_lengths = vocab.encode_batch(CAPTIONS, max_len=15)
    long = encoder(torch.from_numpy(long_ids), long_lengths)
    assert short.shape == (3, 32)
    torch.testing.assert_close(short, long, atol=1e-6, rtol=1e-6)


def test_text_encoder_sees_word_order_and_trains():
    vocab = Vocabulary.build(["walk then jump"])
    encoder = _encoder(vocab)
    ids, lengths = vocab.encode_batch(["walk then jump", "jump then walk"])
    out = encoder(torch.from_numpy(ids), lengths)
    assert not torch.allclose(out[0], out[1], atol=1e-4)
    out.square().sum().backward()
    assert encoder.embedding.weight.grad is not None
    assert encoder.embedding.weight.grad.abs().sum() > 0


def test_text_encoder_rejects_bad_lengths():
    vocab = Vocabulary.build(CAPTIONS)
    encoder = _encoder(vocab)
    ids, _ = vocab.encode_batch(CAPTIONS, max_len=4)
    with pytest.raises(ValueError, match="lengths"):
        encoder(torch.from_numpy(ids), [5, 1, 1])
    with pytest.raises(ValueError, match="dim must be even"):
        TextEncoder(10, dim=33)
