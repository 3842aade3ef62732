"""Decide from joint positions alone whether a motion concept is present.

Input: joints (T, 22, 3) in metres at 20 fps, Y up — world joints or HumanML3D's canonical
``new_joints`` (any start position and heading). The body's facing per frame comes from the
hips and shoulders (forward = across × up, across = (L_hip − R_hip) + (L_shoulder −
R_shoulder)), the floor is the lowest foot joint of the whole clip.

Every concept has a continuous score, the measured quantity divided by a physical threshold,
so a concept is present when its score ≥ 1. The thresholds (:data:`THRESHOLDS`) are set from
what the concept means physically and from human gait facts (e.g. walking turns into
running near 2 m/s; a flight phase of 0.25 s needs a 7.7 cm rise, g·t²/8), never tuned on
generated clips. Which concept owns which signal:

- ``walk_*`` / ``run``: body-frame odometry (per-frame root displacement in the current
  facing frame, summed), its direction, the path's straightness (net / path length), the
  highest 0.5-s mean speed, and steps: the feet must take turns leading along the travel
  direction, so a figure that glides along the path without stepping does not travel.
- ``turn_*`` / ``walk_circle``: the net change of the facing angle (left = +, toward +X);
  ``walk_circle`` needs the steps too.
- ``jump``: the longest stretch with every foot joint off the floor; ``squat``: sustained
  pelvis drop below standing height (estimated from the clip's own leg bones);
  ``kick_*``: one ankle high and ahead of the pelvis while the other foot is grounded.
- ``wave_*``: a wrist above its shoulder swinging side to side; ``raise_arms``: both wrists
  above the head without waving; ``clap``: wrists meeting in front repeatedly;
  ``punch``: the right wrist driven fast to nearly full reach ahead of the shoulder.

For sequential clips evaluate each segment with ``start``/``end`` (frame range, end
exclusive); the floor still comes from the whole clip.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.infra import storage
from repro.motion.features import FPS
from repro.motion.skeleton import JOINT_INDEX, NUM_JOINTS
from repro.standin.dataset import clip_joints

#: name → (threshold, meaning). Physical, fixed before looking at any generated clip.
THRESHOLDS: dict[str, tuple[float, str]] = {
    "displacement": (0.5, "m of body-frame travel: about one step, so a walk is not a sway"),
    "direction_cos": (math.cos(math.radians(30)),
                      "cos of the largest angle between travel and the named direction"),
    "straightness": (0.5, "net displacement / path length of a walk (a circle is ≈ 0)"),
    "run_speed": (2.0, "m/s over 0.5 s: the human walk-to-run transition speed"),
    "step_swing": (0.1, "m the leading foot's lead along the travel direction must change by "
                   "to count: a walking step moves one foot ≈ 0.3–0.7 m past the other, a "
                   "planted stance sways by centimetres"),
    "step_reversals": (1, "changes of which foot leads: one foot steps past the other and the "
                       "other steps past it back, two steps"),
    "turn_min": (math.radians(60), "rad of heading change: clearly more than gait yaw sway"),
    "turn_max": (math.radians(270), "rad: beyond this a turn is a circle"),
    "circle_path": (1.5, "m of path for a walked circle (a turn on the spot walks none)"),
    "airborne_height": (0.05, "m: every foot joint at least this far off the floor"),
    "airborne_frames": (5, "frames (0.25 s) airborne; running flight lasts ≈ 0.1 s"),
    "squat_drop": (0.2, "m the pelvis is below standing height (≈ a quarter leg length)"),
    "squat_frames": (5, "frames (0.25 s) the drop is held"),
    "kick_height": (0.25, "m of kicking-ankle height (ankles rest ≈ 0.05 m up)"),
    "kick_reach": (0.35, "m the kicking ankle is ahead of the pelvis"),
    "grounded": (0.05, "m: a foot joint lower than this touches the floor"),
    "wrist_raised": (0.05, "m a waving wrist is above its shoulder"),
    "wave_swing": (0.05, "m of side-to-side wrist travel that counts as one swing"),
    "wave_reversals": (3, "changes of swing direction: two side-to-side cycles"),
    "raise_frames": (10, "frames (0.5 s) both wrists stay above the head joint"),
    "clap_closed": (0.12, "m between wrists when the palms touch"),
    "clap_open": (0.20, "m between wrists that counts as hands apart"),
    "clap_front": (0.15, "m the wrists' midpoint is ahead of the pelvis"),
    "clap_count": (2, "claps"),
    "punch_reach": (0.40, "m the wrist is ahead of its shoulder (≈ 75 % of arm length)"),
    "punch_speed": (1.5, "m/s forward wrist speed relative to the shoulder within 0.25 s"),
    "punch_height": (0.25, "m the wrist may be above or below shoulder height"),
}

CONCEPT_NAMES: tuple[str, ...] = (
    "walk_forward", "walk_backward", "walk_left", "walk_right", "run", "turn_left",
    "turn_right", "walk_circle", "jump", "squat", "kick_left", "kick_right", "wave_left",
    "wave_right", "wave_both", "raise_arms", "clap", "punch",
)

#: Concepts read from the root's travel and the feet's steps: a figure that glides along a
#: path without its feet taking turns does not travel.
TRAVEL_CONCEPTS: tuple[str, ...] = ("walk_forward", "walk_backward", "walk_left", "walk_right",
                                    "run", "walk_circle")

_J = JOINT_INDEX
_FEET = [_J["L_ankle"], _J["R_ankle"], _J["L_foot"], _J["R_foot"]]


def _limit(name: str) -> float:
    return THRESHOLDS[name][0]


def _as_joints(joints: Any) -> np.ndarray:
    if isinstance(joints, torch.Tensor):
        joints = joints.detach().cpu().numpy()
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if not np.isfinite(joints).all():
        raise ValueError("joints contain NaN or infinite values")
    return joints


def _moving_average(x: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average along axis 0, edges padded with the end values."""
    if width <= 1 or len(x) < 2:
        return x
    pad = width // 2
    padded = np.concatenate([np.repeat(x[:1], pad, 0), x, np.repeat(x[-1:], width - 1 - pad, 0)])
    kernel = np.ones(width) / width
    return np.apply_along_axis(lambda v: np.convolve(v, kernel, mode="valid"), 0, padded)


def _longest_run(mask: np.ndarray) -> int:
    best = current = 0
    for value in mask:
        current = current + 1 if value else 0
        best = max(best, current)
    return best


def _reversals(signal: np.ndarray, swing: float) -> int:
    """Direction changes of ``signal`` after moves of at least ``swing`` (hysteresis)."""
    if len(signal) == 0:
        return 0
    count, direction = 0, 0
    high = low = float(signal[0])
    for value in signal:
        if direction >= 0:
            high = max(high, value)
        if direction <= 0:
            low = min(low, value)
        if direction >= 0 and value <= high - swing:
            count += direction > 0
            direction, low = -1, value
        elif direction <= 0 and value >= low + swing:
            count += direction < 0
            direction, high = 1, value
    return count


class _Body:
    """Per-frame signals of one clip (or one segment of it)."""

    def __init__(self, joints: np.ndarray, start: int, end: int) -> None:
        floor = joints[:, _FEET, 1].min()
        j = joints[start:end].copy()
        j[..., 1] -= floor
        self.j = j
        across = (j[:, _J["L_hip"]] - j[:, _J["R_hip"]]
                  + j[:, _J["L_shoulder"]] - j[:, _J["R_shoulder"]])
        heading = np.unwrap(np.arctan2(-across[:, 2], across[:, 0]))
        self.heading = _moving_average(heading, 5)
        self.forward = np.stack((np.sin(self.heading), np.cos(self.heading)), -1)
        self.left = np.stack((np.cos(self.heading), -np.sin(self.heading)), -1)
        self.root = _moving_average(j[:, 0, [0, 2]], 5)

    def local(self, joint: int, origin: int = 0) -> np.ndarray:
        """(T, 3): joint relative to ``origin`` as (left, up, forward) in the facing frame."""
        rel = self.j[:, joint] - self.j[:, origin]
        return np.stack(((rel[:, [0, 2]] * self.left).sum(-1), self.j[:, joint, 1],
                         (rel[:, [0, 2]] * self.forward).sum(-1)), -1)


def _travel_scores(body: _Body) -> dict[str, float]:
    step = np.diff(body.root, axis=0)
    if len(step) == 0:
        return dict.fromkeys(("walk_forward", "walk_backward", "walk_left", "walk_right",
                              "run", "walk_circle"), 0.0)
    forward_mid = 0.5 * (body.forward[1:] + body.forward[:-1])
    left_mid = 0.5 * (body.left[1:] + body.left[:-1])
    odometry = np.array([(step * forward_mid).sum(), (step * left_mid).sum()])
    length = max(float(np.linalg.norm(odometry)), 1e-9)
    path = float(np.linalg.norm(step, axis=-1).sum())
    straight = float(np.linalg.norm(body.root[-1] - body.root[0])) / max(path, 1e-9)
    window = min(10, len(step))
    windowed = np.linalg.norm(body.root[window:] - body.root[:-window], axis=-1) if \
        len(body.root) > window else np.linalg.norm(body.root[-1:] - body.root[:1], axis=-1)
    peak_speed = float(windowed.max()) * FPS / window
    forward_run = (body.root[window:] - body.root[:-window]) if len(body.root) > window else \
        body.root[-1:] - body.root[:1]
    forward_speed = float(((forward_run * body.forward[:len(forward_run)]).sum(-1)).max()) \
        * FPS / window
    stepped = _steps(body, odometry / length) / _limit("step_reversals")
    d, cos_limit = _limit("displacement"), _limit("direction_cos")
    walk_speed = _limit("run_speed") / max(peak_speed, 1e-9)
    straightness = straight / _limit("straightness")
    scores = {}
    for name, axis, sign in (("walk_forward", 0, 1), ("walk_backward", 0, -1),
                             ("walk_left", 1, 1), ("walk_right", 1, -1)):
        travel = sign * odometry[axis]
        scores[name] = max(0.0, min(travel / d, travel / length / cos_limit, straightness,
                                    walk_speed, stepped))
    scores["run"] = max(0.0, min(forward_speed / _limit("run_speed"), odometry[0] / d,
                                 odometry[0] / length / cos_limit, stepped))
    turned = abs(float(body.heading[-1] - body.heading[0]))
    scores["walk_circle"] = min(turned / _limit("turn_max"), path / _limit("circle_path"),
                                stepped)
    return scores


def _steps(body: _Body, direction: np.ndarray) -> int:
    """How often the leading foot changes along ``direction`` (left, forward) of the facing
    frame: reversals (hysteresis ``step_swing``) of the ankles' lead (L − R) · direction.
    Gliding with the feet still gives 0; walking gives about one per step."""
    lead = body.local(_J["L_ankle"]) - body.local(_J["R_ankle"])
    along = lead[:, 0] * direction[1] + lead[:, 2] * direction[0]
    return _reversals(along, _limit("step_swing"))


def _turn_scores(body: _Body) -> dict[str, float]:
    turned = float(body.heading[-1] - body.heading[0])
    scores = {}
    for name, sign in (("turn_left", 1), ("turn_right", -1)):
        angle = sign * turned
        scores[name] = 0.0 if angle <= 0 else min(angle / _limit("turn_min"),
                                                  _limit("turn_max") / angle)
    return scores


def _leg_scores(body: _Body) -> dict[str, float]:
    feet = body.j[:, _FEET, 1]
    airborne = feet.min(axis=1) >= _limit("airborne_height")
    scores = {"jump": _longest_run(airborne) / _limit("airborne_frames")}
    thigh = np.linalg.norm(body.j[:, [_J["L_hip"], _J["R_hip"]]]
                           - body.j[:, [_J["L_knee"], _J["R_knee"]]], axis=-1)
    shin = np.linalg.norm(body.j[:, [_J["L_knee"], _J["R_knee"]]]
                          - body.j[:, [_J["L_ankle"], _J["R_ankle"]]], axis=-1)
    standing = float(np.median((thigh + shin).mean(axis=1))) + 0.05
    drop = np.where(airborne, 0.0, standing - body.j[:, 0, 1])
    frames = int(_limit("squat_frames"))
    held = (np.lib.stride_tricks.sliding_window_view(drop, frames).min(axis=1)
            if len(drop) >= frames else np.zeros(1))
    scores["squat"] = max(0.0, float(held.max()) / _limit("squat_drop"))
    for name, ankle, other_toe in (("kick_left", _J["L_ankle"], _J["R_foot"]),
                                   ("kick_right", _J["R_ankle"], _J["L_foot"])):
        kick = body.local(ankle)
        grounded = body.j[:, other_toe, 1] < _limit("grounded")
        per_frame = np.minimum(kick[:, 1] / _limit("kick_height"),
                               kick[:, 2] / _limit("kick_reach"))
        scores[name] = max(0.0, float(np.where(grounded, per_frame, 0.0).max()))
    return scores


def _arm_scores(body: _Body) -> dict[str, float]:
    scores = {}
    waving = {}
    for side, prefix in ((0, "L"), (1, "R")):
        wrist = body.local(_J[f"{prefix}_wrist"])
        shoulder = body.local(_J[f"{prefix}_shoulder"])
        raised = wrist[:, 1] - shoulder[:, 1] >= _limit("wrist_raised")
        lateral = wrist[:, 0] - shoulder[:, 0]
        best = 0
        edges = np.flatnonzero(np.diff(np.concatenate(([0], raised.astype(int), [0]))))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            best = max(best, _reversals(lateral[a:b], _limit("wave_swing")))
        waving[side] = best / _limit("wave_reversals")
    scores["wave_left"], scores["wave_right"] = waving[0], waving[1]
    scores["wave_both"] = min(waving[0], waving[1])

    head = body.j[:, _J["head"], 1]
    above = ((body.j[:, _J["L_wrist"], 1] >= head) & (body.j[:, _J["R_wrist"], 1] >= head))
    scores["raise_arms"] = _longest_run(above) / _limit("raise_frames")

    left, right = body.j[:, _J["L_wrist"]], body.j[:, _J["R_wrist"]]
    gap = np.linalg.norm(left - right, axis=-1)
    middle = 0.5 * (body.local(_J["L_wrist"]) + body.local(_J["R_wrist"]))
    in_front = middle[:, 2] >= _limit("clap_front")
    claps, opened = 0, False
    for distance, front in zip(gap, in_front, strict=True):
        if distance > _limit("clap_open"):
            opened = True
        elif opened and front and distance < _limit("clap_closed"):
            claps, opened = claps + 1, False
    scores["clap"] = claps / _limit("clap_count")

    wrist = body.local(_J["R_wrist"]) - body.local(_J["R_shoulder"])
    speed = np.concatenate(([0.0], np.diff(wrist[:, 2]) * FPS))
    recent = _moving_max(speed, 5)
    level = np.abs(wrist[:, 1]) <= _limit("punch_height")
    per_frame = np.minimum(wrist[:, 2] / _limit("punch_reach"), recent / _limit("punch_speed"))
    scores["punch"] = max(0.0, float(np.where(level, per_frame, 0.0).max()))
    return scores


def _moving_max(x: np.ndarray, width: int) -> np.ndarray:
    """max of x over the current and the previous ``width − 1`` frames."""
    padded = np.concatenate((np.full(width - 1, -np.inf), x))
    return np.lib.stride_tricks.sliding_window_view(padded, width).max(axis=1)


def _frame_range(n: int, start: int | None, end: int | None) -> tuple[int, int]:
    start = 0 if start is None else int(start)
    end = n if end is None else int(end)
    if not 0 <= start < end <= n:
        raise ValueError(f"frame range [{start}, {end}) is not inside a clip of {n} frames")
    if end - start < 2:
        raise ValueError(f"frame range [{start}, {end}) has fewer than 2 frames")
    return start, end


def concept_scores(joints: Any, *, start: int | None = None,
                   end: int | None = None) -> dict[str, float]:
    """Score of every concept on frames [start, end) (default: all); present iff ≥ 1.

    Each score is a measured quantity over its physical threshold (:data:`THRESHOLDS`);
    multi-condition concepts take the minimum over their conditions. ``wave_left`` and
    ``wave_right`` score each arm alone; :func:`concept_present` makes them exclusive of
    ``wave_both``.
    """
    joints = _as_joints(joints)
    start, end = _frame_range(len(joints), start, end)
    body = _Body(joints, start, end)
    scores = {**_travel_scores(body), **_turn_scores(body), **_leg_scores(body),
              **_arm_scores(body)}
    return {name: float(scores[name]) for name in CONCEPT_NAMES}


def _present(scores: Mapping[str, float]) -> set[str]:
    found = {name for name, score in scores.items() if score >= 1.0}
    if {"wave_left", "wave_right"} <= found:
        found -= {"wave_left", "wave_right"}       # both arms waving is wave_both
    if found & {"wave_left", "wave_right", "wave_both"}:
        found.discard("raise_arms")                # raised arms that wave are waving
    return found


def detect_concepts(joints: Any, *, start: int | None = None,
                    end: int | None = None) -> set[str]:
    """The concepts present on frames [start, end): scores ≥ 1, with two exclusions —
    both arms waving counts as ``wave_both`` only, and raised arms that wave are not
    ``raise_arms``."""
    return _present(concept_scores(joints, start=start, end=end))


def concept_present(joints: Any, concept: str, *, start: int | None = None,
                    end: int | None = None) -> bool:
    """Whether ``concept`` is among :func:`detect_concepts` on frames [start, end)."""
    if concept not in CONCEPT_NAMES:
        raise ValueError(f"unknown concept {concept!r}; known: {', '.join(CONCEPT_NAMES)}")
    return concept in detect_concepts(joints, start=start, end=end)


def detect_segments(joints: Any, segments: Sequence[Mapping[str, Any]]) -> list[set[str]]:
    """:func:`detect_concepts` on each labelled segment (dicts with ``start`` and ``end``)."""
    return [detect_concepts(joints, start=s["start"], end=s["end"]) for s in segments]


# ---------------------------------------------------------------------------- agreement

def _units(joints: np.ndarray, labels: Mapping[str, Any]) -> list[tuple[set[str], set[str], str]]:
    """(truth, detected, composition) per evaluation unit: the whole clip, or each segment
    of a sequential clip."""
    kind = labels["composition"]
    if kind == "sequential":
        return [({s["concept"]}, detect_concepts(joints, start=s["start"], end=s["end"]), kind)
                for s in labels["segments"]]
    return [(set(labels["concepts"]), detect_concepts(joints), kind)]


def _iter_dataset(directory: Path, split: str | None) -> Iterable[tuple[np.ndarray, dict]]:
    if split is not None:
        ids = (directory / f"{split}.txt").read_text().split()
    else:
        ids = sorted(p.stem for p in (directory / "labels").glob("*.json"))
    if not ids:
        raise ValueError(f"no labelled clips found in {directory}")
    for clip_id in ids:
        labels = storage.read_json(directory / "labels" / f"{clip_id}.json")
        yield clip_joints(directory, clip_id), labels


def _ratio(numerator: int, denominator: int) -> float | None:
    return numerator / denominator if denominator else None


def oracle_agreement(source: str | Path | Iterable[Any], *,
                     split: str | None = None) -> dict[str, Any]:
    """How often the oracles agree with the generator's labels.

    ``source``: a HumanML3D-layout folder with ``labels/`` (optionally one ``split``), or
    an iterable of clips (objects with ``joints`` and ``labels``, or (joints, labels)
    pairs). Each single or simultaneous clip is one unit (truth = its concepts); each
    segment of a sequential clip is one unit (truth = that segment's concept).

    Returns ``n_units``, ``exact_match`` (detected set == truth), ``per_concept``
    (tp, fp, fn, precision, recall, support), ``by_composition`` (units, exact_match,
    all_truth_detected) and ``confusions`` (truth → wrongly added or missed concepts).
    """
    if isinstance(source, str | Path):
        directory = Path(source)
        if not (directory / "labels").is_dir():
            raise ValueError(f"{directory} has no labels/ folder")
        clips: Iterable[Any] = _iter_dataset(directory, split)
    else:
        if split is not None:
            raise ValueError("split applies to a dataset folder, not to a list of clips")
        clips = source
    counts = {name: {"tp": 0, "fp": 0, "fn": 0} for name in CONCEPT_NAMES}
    by_kind: dict[str, dict[str, int]] = {}
    confusions: dict[str, dict[str, int]] = {}
    units = exact = 0
    for item in clips:
        joints, labels = (item.joints, item.labels) if hasattr(item, "labels") else item
        for truth, detected, kind in _units(_as_joints(joints), labels):
            units += 1
            exact += truth == detected
            stats = by_kind.setdefault(kind, {"units": 0, "exact": 0, "all_truth": 0})
            stats["units"] += 1
            stats["exact"] += truth == detected
            stats["all_truth"] += truth <= detected
            for name in CONCEPT_NAMES:
                counts[name]["tp"] += name in truth and name in detected
                counts[name]["fp"] += name not in truth and name in detected
                counts[name]["fn"] += name in truth and name not in detected
            key = "+".join(sorted(truth))
            for name in (detected - truth) | {f"missed:{m}" for m in truth - detected}:
                confusions.setdefault(key, {}).setdefault(name, 0)
                confusions[key][name] += 1
    per_concept = {
        name: {**c, "support": c["tp"] + c["fn"],
               "precision": _ratio(c["tp"], c["tp"] + c["fp"]),
               "recall": _ratio(c["tp"], c["tp"] + c["fn"])}
        for name, c in counts.items()
    }
    return {
        "n_units": units, "exact_match": _ratio(exact, units), "per_concept": per_concept,
        "by_composition": {k: {"units": v["units"], "exact_match": _ratio(v["exact"], v["units"]),
                               "all_truth_detected": _ratio(v["all_truth"], v["units"])}
                           for k, v in sorted(by_kind.items())},
        "confusions": confusions,
    }
