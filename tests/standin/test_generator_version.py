"""A change to the generated motion must come with a new GENERATOR_VERSION, because cached
datasets (and every model trained on them) are keyed by it. This pins what the current version
generates: if the motion changes and the version does not, this fails."""

from __future__ import annotations

import hashlib

import numpy as np

from repro.standin.generator import GENERATOR_VERSION, generate_clip, sample_clip_spec

#: sha256 of a few clips' joints (rounded to 0.1 mm) and captions, per generator version.
PINNED = {"2": "93057da6342131fe41b20f0eb4f1cf853804b16e48011517b0d67b9ac54d6e42",
          "3": "6202039df6cf505ca28e795efedc9deef22593f64ecb0a0542b5866376843e4f"}


def _fingerprint() -> str:
    digest = hashlib.sha256()
    for i in range(6):
        spec = sample_clip_spec(np.random.default_rng([7, i]))
        clip = generate_clip(spec, seed=i)
        digest.update(np.round(clip.joints.astype(np.float64), 4).tobytes())
        digest.update("|".join(clip.captions).encode())
    return digest.hexdigest()


def test_generated_motion_matches_the_pinned_version() -> None:
    assert GENERATOR_VERSION in PINNED, (
        f"GENERATOR_VERSION {GENERATOR_VERSION!r} has no pinned fingerprint; add "
        f"{_fingerprint()!r}")
    assert _fingerprint() == PINNED[GENERATOR_VERSION], (
        "the generator's output changed: bump GENERATOR_VERSION (cached datasets and models "
        "depend on it) and pin the new fingerprint")
