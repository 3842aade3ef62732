"""Procedural, concept-driven stand-in clips: what to generate (:class:`ClipSpec`, defined in
``repro.standin.clip_spec`` and re-exported here), how concepts compose, and the generated
:class:`Clip`.

Every clip is made by forward kinematics (``skeleton.forward_kinematics``) from a root
trajectory and per-joint local rotations on HumanML3D's target skeleton, so bone lengths are
exactly those of REFERENCE.md in every frame. Clips last 2–6 s at 20 fps (41–121 raw frames,
hence 40–120 feature frames: inside the loaders' 40 ≤ T < 200).

Each concept (``repro.standin.concepts``) is a parameter sampler and a motion filling a
:class:`~repro.standin.pose.Track`, which :func:`~repro.standin.pose.solve_pose` turns into
local rotations. This module draws clip specifications, composes concepts and solves clips;
``repro.standin.captions`` words them and ``repro.standin.dataset`` writes datasets.

Composition by body part: simultaneous concepts (two, or three as MTT's sets of three texts)
each give the parts they own (``repro.standin.concepts``). Sequential concepts are evaluated
one after the other, each starting where the previous one left the root, and cross-faded over
:data:`BLEND_FRAMES` frames around each transition.

Version 3: a share :data:`PARTIAL_CAPTION_SHARE` of a multi-concept clip's captions
name only some of its concepts, and a single-concept clip's unowned parts move freely
(``repro.standin.variation``), so the clips of a single-concept text span the others.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import torch

from repro.motion.features import FPS, joints_to_features
from repro.motion.skeleton import forward_kinematics
from repro.standin.captions import humanml3d_text_line, sample_named_captions
from repro.standin.clip_spec import (
    COMPOSITIONS,
    MAX_DURATION,
    MIN_DURATION,
    PARTIAL_CAPTION_SHARE,
    ClipSpec,
)
from repro.standin.concepts import (
    BODY_PARTS,
    CONCEPTS,
    can_be_simultaneous,
    check_concept,
)
from repro.standin.pose import Track, solve_pose, take_part
from repro.standin.primitives import idle, place, slerp_directions, smoothstep
from repro.standin.variation import free_variation

__all__ = [
    "BLEND_FRAMES", "COMPOSITIONS", "DEFAULT_COMPOSITION_WEIGHTS", "GENERATOR_VERSION",
    "MAX_DURATION", "MIN_DURATION", "PARTIAL_CAPTION_SHARE", "Clip", "ClipSpec", "free_parts",
    "clip_captions", "clip_features", "generate_clip", "generate_clips", "sample_clip_spec",
]

#: bump when the generated motion or texts change, so cached datasets are regenerated
#: (tests/standin/test_generator_version.py pins what each version generates). 2: the motion fixes
#: made after the first datasets were cached under 1. 3: partial captions of multi-concept clips
#: and freely moving unowned parts in single-concept clips (docs/GENERATOR_V3.md).
GENERATOR_VERSION = "3"
#: cross-fade length at a sequential transition (frames, centred on the boundary).
BLEND_FRAMES = 8


# ---------------------------------------------------------------------------- clip specs

DEFAULT_COMPOSITION_WEIGHTS: dict[str, float] = {
    "single": 0.5, "simultaneous": 0.3, "sequential": 0.2}


def _frames(seconds: float) -> float:
    """Round a duration to whole frames."""
    return round(seconds * FPS) / FPS


def sample_clip_spec(rng: np.random.Generator, *, allow_compositions: bool = True,
                     concept_pool: Sequence[str] | None = None,
                     composition_weights: Mapping[str, float] | None = None,
                     partial_caption_share: float = PARTIAL_CAPTION_SHARE) -> ClipSpec:
    """Draw a random clip specification: a composition kind (by ``composition_weights``,
    default 50 % single, 30 % simultaneous, 20 % sequential), concepts from ``concept_pool``
    (default all), a duration in [2, 6] s long enough for them, a random initial heading and
    start position; captions partial at ``partial_caption_share``."""
    share = partial_caption_share
    pool = list(concept_pool) if concept_pool is not None else list(CONCEPTS)
    if not pool:
        raise ValueError("concept_pool is empty")
    for name in pool:
        check_concept(name)
    weights = dict(composition_weights or DEFAULT_COMPOSITION_WEIGHTS)
    if not allow_compositions:
        weights = {"single": 1.0}
    for kind, weight in weights.items():
        if kind not in COMPOSITIONS:
            raise ValueError(f"unknown composition {kind!r}; known: {COMPOSITIONS}")
        if weight < 0:
            raise ValueError(f"composition weight for {kind!r} is negative: {weight}")
    kinds = [k for k in COMPOSITIONS if weights.get(k, 0.0) > 0]
    if not kinds:
        raise ValueError(f"composition weights select nothing: {weights}")
    probabilities = np.array([weights[k] for k in kinds]) / sum(weights[k] for k in kinds)
    kind = str(rng.choice(kinds, p=probabilities))
    params = {"initial_heading": float(rng.uniform(-np.pi, np.pi)),
              "start_xz": [float(v) for v in rng.uniform(-1.0, 1.0, 2)]}

    if kind == "single":
        name = str(rng.choice(pool))
        shortest = max(MIN_DURATION, CONCEPTS[name].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((name,), "single", duration, params, partial_caption_share=share)

    if kind == "simultaneous":
        pairs = [(a, b) for a in pool for b in pool if a < b and can_be_simultaneous(a, b)]
        if not pairs:
            raise ValueError(f"no two concepts in {pool} own disjoint body parts")
        a, b = pairs[int(rng.integers(len(pairs)))]
        first, second = sorted((a, b), key=lambda n: (not CONCEPTS[n].moves_root,
                                                      "left_arm" not in CONCEPTS[n].parts))
        shortest = max(MIN_DURATION, CONCEPTS[a].min_duration, CONCEPTS[b].min_duration)
        duration = _frames(rng.uniform(shortest, MAX_DURATION))
        return ClipSpec((first, second), "simultaneous", duration, params,
                        partial_caption_share=share)

    pairs = [(a, b) for a in pool for b in pool
             if a != b and CONCEPTS[a].min_duration + CONCEPTS[b].min_duration <= MAX_DURATION]
    if not pairs:
        raise ValueError(f"no two different concepts in {pool} fit in {MAX_DURATION} s")
    a, b = pairs[int(rng.integers(len(pairs)))]
    mins = np.array([CONCEPTS[a].min_duration, CONCEPTS[b].min_duration])
    extra = rng.uniform(0.0, MAX_DURATION - mins.sum())
    split = rng.uniform(0.3, 0.7)
    first = _frames(mins[0] + extra * split)
    second = _frames(mins[1] + extra * (1 - split))
    duration = _frames(first + second)
    return ClipSpec((a, b), "sequential", duration, params, (first, duration - first), share)


# ----------------------------------------------------------------------------- composing

def _concept_track(name: str, t: np.ndarray, p: Mapping[str, Any], sway: float) -> Track:
    """A single concept's track at the origin: its own motion for root-owning concepts,
    idle standing with the concept's arms otherwise."""
    concept = CONCEPTS[name]
    track = concept.motion(t, p)
    if concept.moves_root:
        return track
    base = idle(t, sway)
    for part in concept.parts:
        take_part(base, track, part)
    return base


def _simultaneous(names: Sequence[str], t: np.ndarray, params: Mapping[str, Mapping[str, Any]],
                  sway: float) -> tuple[Track, dict[str, str]]:
    """Each body part from the concept that owns it; a root-owning concept's secondary
    parts (its arm swing) fill parts nobody owns; idle standing fills the rest."""
    owners = {part: "idle" for part in BODY_PARTS}
    base_name = next((n for n in names if CONCEPTS[n].moves_root), None)
    if base_name is None:
        track = idle(t, sway)
    else:
        track = CONCEPTS[base_name].motion(t, params[base_name])
        owners = {part: base_name for part in BODY_PARTS}
    for name in names:
        if name == base_name:
            continue
        own = CONCEPTS[name].motion(t, params[name])
        for part in CONCEPTS[name].parts:
            take_part(track, own, part)
            owners[part] = name
    return track, owners


def _blend(into: Track, other: Track, frames: np.ndarray, weight: np.ndarray) -> None:
    """Cross-fade ``into`` toward ``other`` on ``frames`` (arm directions along great
    circles, everything else linearly)."""
    for f in fields(into):
        if f.name == "arms":
            continue
        a = getattr(into, f.name)
        w = weight.reshape((-1,) + (1,) * (a.ndim - 1))
        a[frames] = (1 - w) * a[frames] + w * getattr(other, f.name)
    into.arms[frames] = slerp_directions(into.arms[frames], other.arms, weight[:, None, None])


def _sequential(names: Sequence[str], durations: Sequence[float], n_frames: int,
                params: Mapping[str, Mapping[str, Any]], start_xz: np.ndarray,
                heading: float, sway: float) -> tuple[Track, list[int]]:
    """Concepts one after another, each starting where the previous left the root; the
    cross-fade spans ``BLEND_FRAMES`` centred on each boundary."""
    bounds = [0] + [int(round(FPS * s)) for s in np.cumsum(durations)[:-1]] + [n_frames]
    half = BLEND_FRAMES // 2
    frames = np.arange(n_frames)
    out: Track | None = None
    origin, facing = np.asarray(start_xz, float), heading
    for i, name in enumerate(names):
        lo = 0 if i == 0 else max(0, bounds[i] - half)
        hi = n_frames if i == len(names) - 1 else min(n_frames, bounds[i + 1] + half)
        local_t = (frames[lo:hi] - bounds[i]) / FPS
        track = place(_concept_track(name, local_t, params[name], sway), origin, facing)
        if out is None:
            out = idle(frames / FPS, sway)
            for f in fields(out):
                getattr(out, f.name)[lo:hi] = getattr(track, f.name)
        else:
            window = frames[lo:bounds[i] + half]
            weight = smoothstep((window - lo + 0.5) / (bounds[i] + half - lo))
            _blend(out, _slice(track, 0, len(window)), window, weight)
            for f in fields(out):
                getattr(out, f.name)[bounds[i] + half:hi] = getattr(track, f.name)[len(window):]
        if i + 1 < len(names):
            k = bounds[i + 1] - lo
            origin, facing = track.root_xz[k].copy(), float(track.heading[k])
    assert out is not None
    return out, bounds


def _slice(track: Track, start: int, stop: int) -> Track:
    return Track(**{f.name: getattr(track, f.name)[start:stop] for f in fields(track)})


# ------------------------------------------------------------------------------------ clips

@dataclass(frozen=True)
class Clip:
    """A generated clip: world joints (T, 22, 3) float32 at 20 fps, the root positions and
    local rotations (w, x, y, z) that made them, captions and machine-readable labels."""

    joints: np.ndarray
    root: np.ndarray
    rotations: np.ndarray
    captions: tuple[str, ...]
    labels: dict[str, Any]

    def text_lines(self) -> list[str]:
        """The captions as HumanML3D text lines (whole clip: ``#0.0#0.0``)."""
        return [humanml3d_text_line(c) for c in self.captions]


def _concept_params(spec: ClipSpec, rng: np.random.Generator) -> dict[str, dict[str, Any]]:
    durations = spec.segment_durations or (spec.duration,) * len(spec.concepts)
    params: dict[str, dict[str, Any]] = {}
    for i, (name, duration) in enumerate(zip(spec.concepts, durations, strict=True)):
        concept = CONCEPTS[name]
        stop = spec.composition == "sequential" and i + 1 < len(spec.concepts)
        drawn = concept.sample(rng, float(duration), stop)
        overrides = dict(spec.params.get(name, {}))
        unknown = sorted(set(overrides) - set(drawn))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} for concept {name!r}; known: "
                             f"{sorted(drawn)}")
        drawn.update(overrides)
        params[name] = drawn
    return params


def free_parts(concept: str) -> tuple[str, ...]:
    """The body parts a single-concept clip of ``concept`` lets move freely
    (``variation.free_variation``): every part it does not own except the root, which never
    travels unless the concept moves it."""
    owned = CONCEPTS[concept].parts
    return tuple(part for part in BODY_PARTS if part not in owned and part != "root")


def _plan(spec: ClipSpec, seed: int) -> tuple[Track, tuple[str, ...], dict[str, Any]]:
    """The track, captions and labels of a clip (everything but the pose solve)."""
    if not isinstance(spec, ClipSpec):
        raise ValueError(f"spec must be a ClipSpec, got {type(spec).__name__}")
    rng = np.random.default_rng(seed)
    unknown = sorted(set(spec.params) - set(spec.concepts) - {"initial_heading", "start_xz"})
    if unknown:
        raise ValueError(f"unknown spec.params key(s) {unknown}; allowed: initial_heading, "
                         f"start_xz and the clip's concept names")
    heading = float(spec.params.get("initial_heading", 0.0))
    start_xz = np.asarray(spec.params.get("start_xz", (0.0, 0.0)), dtype=np.float64)
    if start_xz.shape != (2,):
        raise ValueError(f"start_xz must be two numbers, got {spec.params.get('start_xz')!r}")
    sway = float(rng.uniform(0, 2 * np.pi))
    params = _concept_params(spec, rng)
    n = spec.n_frames
    t = np.arange(n) / FPS
    last = n - 1                                   # features drop the last raw frame
    if spec.composition == "sequential":
        assert spec.segment_durations is not None
        track, bounds = _sequential(spec.concepts, spec.segment_durations, n, params,
                                    start_xz, heading, sway)
        half = BLEND_FRAMES // 2
        segments = [{"concept": name, "start": bounds[i], "end": min(bounds[i + 1], last),
                     "body_parts": {part: (name if part in CONCEPTS[name].parts
                                           or CONCEPTS[name].moves_root else "idle")
                                    for part in BODY_PARTS}}
                    for i, name in enumerate(spec.concepts)]
        transitions = bounds[1:-1]
        windows = [[b - half, b + half] for b in transitions]
        owners: dict[str, Any] = {}
    else:
        track, owners = _simultaneous(spec.concepts, t, params, sway)
        if spec.composition == "single":
            free = free_parts(spec.concepts[0])
            free_variation(track, free, t, rng)
            owners.update({part: "free" for part in free})
        track = place(track, start_xz, heading)
        segments = [{"concept": name, "start": 0, "end": last} for name in spec.concepts]
        transitions, windows = [], []
    named = sample_named_captions(spec, rng, partial_share=spec.partial_caption_share)
    captions = tuple(caption for caption, _ in named)
    labels = {
        "concepts": list(spec.concepts), "composition": spec.composition, "fps": FPS,
        "caption_concepts": [list(names) for _, names in named],
        "n_frames": n, "segments": segments, "transitions": transitions,
        "transition_windows": windows, "body_parts": owners,
        "params": {"initial_heading": heading, "start_xz": start_xz.tolist(), "sway": sway,
                   **params},
        "seed": int(seed),
    }
    return track, captions, labels


def generate_clips(specs: Sequence[ClipSpec], seeds: Sequence[int]) -> list[Clip]:
    """:func:`generate_clip` for many clips at once: the pose solve and forward kinematics
    are per frame, so all clips' frames go through them in one batch (much faster)."""
    if len(specs) != len(seeds):
        raise ValueError(f"{len(specs)} specs but {len(seeds)} seeds")
    plans = [_plan(spec, seed) for spec, seed in zip(specs, seeds, strict=True)]
    if not plans:
        return []
    whole = Track(**{f.name: np.concatenate([getattr(track, f.name) for track, _, _ in plans])
                     for f in fields(Track)})
    root, rotations = solve_pose(whole)
    joints = forward_kinematics(root, rotations)
    clips, start = [], 0
    for track, captions, labels in plans:
        stop = start + len(track.heading)
        clips.append(Clip(joints=joints[start:stop].numpy().astype(np.float32),
                          root=root[start:stop].numpy().astype(np.float32),
                          rotations=rotations[start:stop].numpy().astype(np.float32),
                          captions=captions, labels=labels))
        start = stop
    return clips


def clip_captions(spec: ClipSpec, seed: int) -> tuple[str, ...]:
    """The captions :func:`generate_clip` gives ``(spec, seed)``, without solving the pose."""
    return _plan(spec, seed)[1]


def clip_features(clips: Sequence[Clip]) -> list[tuple[np.ndarray, np.ndarray]]:
    """``joints_to_features`` (features, canonical joints) of each clip, computed in batches
    of equal-length clips (the function is batched over leading dims, so each clip's result
    is what it gives alone, up to float rounding)."""
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(clips)
    for length in sorted({len(c.joints) for c in clips}):
        members = [i for i, c in enumerate(clips) if len(c.joints) == length]
        features, canonical = joints_to_features(np.stack([clips[i].joints for i in members]))
        for k, i in enumerate(members):
            out[i] = (features[k], canonical[k])
    return out  # type: ignore[return-value]


def generate_clip(spec: ClipSpec, seed: int) -> Clip:
    """Generate one clip, deterministically from ``(spec, seed)``.

    Labels: ``concepts`` (every concept the motion holds), ``caption_concepts`` (per caption,
    the concepts it names: all of them, or some for a partial caption), ``composition``,
    ``segments`` (concept, start, end frames, end
    exclusive, raw-frame indices — the same indices address ``new_joints`` / features, whose
    last raw frame is dropped), ``transitions`` (boundary frames) and ``transition_windows``,
    ``body_parts`` (part → owning concept, "idle", or "free" where a single-concept clip's
    unowned part moves freely; per segment for sequential clips),
    ``params`` (every drawn parameter) and ``fps``.
    """
    return generate_clips([spec], [seed])[0]


def _benchmark(n_clips: int = 200) -> dict[str, float]:
    """Seconds per clip for generation alone and generation + features (one thread)."""
    torch.set_num_threads(1)
    specs = [sample_clip_spec(np.random.default_rng([0, i])) for i in range(n_clips)]
    start = time.perf_counter()
    clips = [generate_clip(s, i) for i, s in enumerate(specs)]
    generate = time.perf_counter() - start
    start = time.perf_counter()
    for clip in clips:
        joints_to_features(clip.joints)
    features = time.perf_counter() - start
    return {"generate_s_per_clip": generate / n_clips, "features_s_per_clip": features / n_clips}
