"""GMD-B2: asking a trajectory model for locations, like for like in both root representations.

GMD appendix B: "imputing specific values becomes ill-posed [in rel] since there are many
possible sets of values that are satisfiable. On the other hand, for abs, the imputation and
optimization of z become straightforward as they only involve replacing or updating z(i)".
So the comparison is made twice, each mechanism against itself:

* **imputation** — abs: the world x/z entries at the target frames *are* the locations and
  are replaced (:func:`abs_location_imputation`). rel: no entry holds a location; p_i is a
  cumulative sum of every earlier frame's heading and velocity, so a replacement has to fix
  all of them, and one of the many satisfying sets has to be picked
  (:func:`rel_location_imputation`, the choice and its reason there).
* **guidance** — the same L1 goal on the root recovered from x̂0, the same strength and stop
  step, in both (:func:`location_loss`).

Both mechanisms act while t ≥ the stop step: GMD's trajectory model imputes its key
locations and is guided while t ≥ 20 of T = 1000 (GMD appendix F; ``repro.gmd.guidance``:
imputation and guidance stop at the same step). The free steps after it are where a rel
sample's small changes compound into its locations (GMD-B1).

This module holds the location task, both imputations and every method's sampling
(:func:`impute_locations`), the controls, the notebook's runs, gate records, figures, reading
and result (:func:`b2_result`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from repro.claims.result import ClaimResult, Controls
from repro.core.diffusion import Guidance, Imputation
from repro.core.tables import interval_text, markdown_table, render
from repro.gmd import model_gates
from repro.gmd import settings as rule_settings
from repro.gmd.controls import (
    AAReadings,
    Slot,
    aa_controls,
    aa_readings,
    control_seed,
    draw_indices,
    located,
    reference_model,
)
from repro.gmd.figures import count_below, either
from repro.gmd.guidance import GMD_GUIDANCE_STRENGTH, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import TrainedGMD, describe
from repro.gmd.root_representation.common import (
    REPRESENTATION_ROLES,
    FigurePath,
    Settings,
    Windows,
)
from repro.gmd.windows import (
    REPRESENTATIONS,
    FeatureSpace,
    MotionWindows,
    short_label,
)
from repro.motion.features import FEATURE_DIM, absolute_to_relative_root

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["B2_SLOTS", "B2_THRESHOLD", "ImputationRun", "LocationTask", "METHODS",
           "REGISTERED_METHODS", "abs_location_imputation", "b2_aa_readings",
           "b2_controls", "b2_model_records", "b2_result", "b2_runs",
           "b2_table_markdown", "facing_path_root", "impute_locations",
           "location_errors", "location_loss", "location_task", "plot_imputation",
           "plot_method_errors", "reading_b2", "registered_measurements",
           "rel_location_imputation"]


#: the methods run on every seed: unguided, imputation and guidance in each representation.
METHODS = ("abs_unguided", "abs_imputation", "abs_guidance",
           "rel_unguided", "rel_imputation", "rel_guidance")


#: a method's registered measurement: ``<method>_error`` (the mean location error, m).
REGISTERED_METHODS = ("abs_imputation", "rel_imputation", "abs_guidance", "rel_guidance")


@dataclass(frozen=True)
class LocationTask:
    """Reach a waypoint at ``waypoint_frame`` and a goal at the last frame (GMD-B2).

    ``targets`` (n, 2, 2): for each sample the world x/z at the waypoint and at the goal,
    taken from one test window each (places a motion of the data set does reach in time).
    """

    targets: np.ndarray
    waypoint_frame: int
    goal_frame: int

    @property
    def frames(self) -> tuple[int, int]:
        return (self.waypoint_frame, self.goal_frame)

    @property
    def n(self) -> int:
        return int(self.targets.shape[0])


def location_task(test_windows: MotionWindows, n: int, *, seed: int) -> LocationTask:
    """n waypoint/goal pairs from n test windows drawn with ``seed``: the waypoint frame is
    the middle frame (frames/2 − 1), the goal frame the last."""
    frames = test_windows.frames
    waypoint = frames // 2 - 1
    if n > len(test_windows):
        raise ValueError(f"asked for {n} targets from {len(test_windows)} windows")
    picks = np.random.default_rng(seed).choice(len(test_windows), n, replace=False)
    space = test_windows.space("trajectory")
    with torch.no_grad():
        path = space.root_xz(test_windows.trajectory()[torch.from_numpy(picks)]).numpy()
    targets = path[:, [waypoint, frames - 1]]
    return LocationTask(targets.astype(np.float32), waypoint, frames - 1)


def location_loss(space: FeatureSpace, task: LocationTask) -> Callable[[Tensor], Tensor]:
    """G(x̂0) = Σ_{i ∈ {waypoint, goal}} ‖p_xz(i) − target_i‖₁ (m) per sample: GMD's L1 goal
    function on the un-normalised root of x̂0, summed over the two target frames."""
    frames = list(task.frames)

    def goal(pred_x0: Tensor) -> Tensor:
        position = space.root_xz(pred_x0)[:, frames]                       # (B, 2, 2)
        target = torch.as_tensor(task.targets, dtype=position.dtype, device=position.device)
        return (position - target).abs().sum(dim=(1, 2))

    return goal


def location_errors(space: FeatureSpace, x: Tensor, task: LocationTask) -> np.ndarray:
    """Euclidean distance (m) of the root x/z to each target, (n, 2): waypoint, goal."""
    with torch.no_grad():
        position = space.root_xz(x.detach())[:, list(task.frames)].cpu().numpy()
    return np.linalg.norm(position - task.targets, axis=-1)


def _normalised(space: FeatureSpace, channel: int, values: np.ndarray) -> np.ndarray:
    return (values - space.mean[channel]) / space.std[channel]


def abs_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """abs: the root x/z entries (channels 1, 2) at the two target frames *are* the targets —
    replace them (GMD's ε-model imputation: x_{t−1} ← q_sample(target, t−1) on the mask, the
    target itself at t = 0); nothing else is touched."""
    if space.representation != "absolute":
        raise ValueError("abs_location_imputation needs an absolute-root model")
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    target = torch.zeros(task.n, space.channels, frames)
    for k, frame in enumerate(task.frames):
        mask[0, 1:3, frame] = True
        for c in (1, 2):
            target[:, c, frame] = torch.from_numpy(
                _normalised(space, c, task.targets[:, k, c - 1]).astype(np.float32))
    return Imputation(mask, target)


def _facing_half_angle(direction: np.ndarray) -> np.ndarray:
    """The heading half-angle a whose facing frame walks forward (+Z local) along the world
    x/z ``direction`` (..., 2): ``recover_root`` moves a local step (0, 0, v) by R(2a)⁻¹,
    i.e. to (−sin 2a, cos 2a)·v, so 2a = atan2(−d_x, d_z)."""
    return 0.5 * np.arctan2(-direction[..., 0], direction[..., 1])


def facing_path_root(task: LocationTask, frames: int) -> np.ndarray:
    """The rel root entries (n, frames, 3) — half-angle velocity ω and facing-frame x/z
    velocity v — of walking from the origin straight to the waypoint and on to the goal at a
    constant speed per leg, facing the direction of travel (a turn at the first step and at
    the waypoint). Built as an abs path (heading a_t, world p_t) and differenced with
    ``absolute_to_relative_root``, so ``recover_root`` reproduces p_t exactly; the last
    frame's entries repeat the previous frame's (never read)."""
    i, last = task.frames
    waypoint, goal = task.targets[:, 0].astype(np.float64), task.targets[:, 1].astype(np.float64)
    t = np.arange(frames, dtype=np.float64)[None, :, None]
    first_leg = waypoint[:, None, :] * np.minimum(t / i, 1.0)
    second_leg = (goal - waypoint)[:, None, :] * np.clip((t - i) / (last - i), 0.0, 1.0)
    position = first_leg + second_leg                                       # (n, frames, 2)
    heading_first = _facing_half_angle(waypoint)
    # the turn at the waypoint takes the shorter way round (2a unwrapped to within ±π)
    turn = np.angle(np.exp(2j * (_facing_half_angle(goal - waypoint) - heading_first))) / 2
    heading = np.zeros((task.n, frames))
    heading[:, 1:i + 1] = heading_first[:, None]
    heading[:, i + 1:] = (heading_first + turn)[:, None]
    absolute = np.zeros((task.n, frames, FEATURE_DIM))
    absolute[..., 0] = heading
    absolute[..., 1:3] = position
    return np.asarray(absolute_to_relative_root(absolute))[..., :3]


def rel_location_imputation(space: FeatureSpace, task: LocationTask,
                            frames: int) -> Imputation:
    """rel: no entry holds p_i, which depends on ω_s and v_s of every s < i, so an imputation
    that guarantees both locations must fix channels 0–2 of *every* frame (only the root
    height, channel 3, is left to the model) — GMD's code imputes a rel (MDM) model the same
    way, overwriting the root rotation and x/z velocity of all frames with those of a whole
    given trajectory. Two locations leave infinitely many such trajectories; we impute
    :func:`facing_path_root` (straight legs, facing the direction of travel), the one that
    asks nothing the locations do not imply and walks forward as the data do."""
    if space.representation != "relative":
        raise ValueError("rel_location_imputation needs a relative-root model")
    root = facing_path_root(task, frames)
    mask = torch.zeros(1, space.channels, frames, dtype=torch.bool)
    mask[0, 0:3, :] = True
    target = torch.zeros(task.n, space.channels, frames)
    for c in range(3):
        target[:, c, :] = torch.from_numpy(_normalised(space, c, root[..., c]).astype(np.float32))
    return Imputation(mask, target)


@dataclass
class ImputationRun:
    """One method on one model: the samples (model space) and what was measured."""

    method: str
    samples: Tensor
    location_error: np.ndarray        # (n, 2) m: waypoint, goal
    root_acceleration: float          # m/s², mean over frames (jitter_of, root)
    path_change: float                # m, mean ‖p_t − p_t(unguided, same seed)‖ over all t
    path_change_off_target: float     # m, the same over frames ≥ 3 away from both targets

    @property
    def mean_error(self) -> float:
        return float(self.location_error.mean())

    def summary(self) -> dict[str, float]:
        return {"location_error": self.mean_error,
                "waypoint_error": float(self.location_error[:, 0].mean()),
                "goal_error": float(self.location_error[:, 1].mean()),
                "root_acceleration": self.root_acceleration, "path_change": self.path_change,
                "path_change_off_target": self.path_change_off_target}


def impute_locations(models: Mapping[str, TrainedGMD], task: LocationTask, *, seed: int,
                     stop_t: int, clip_x0: float | None,
                     strength: float = GMD_GUIDANCE_STRENGTH,
                     representations: Sequence[str] = REPRESENTATIONS,
                     ) -> dict[str, ImputationRun]:
    """Every method of :data:`METHODS` from the same seed (same x_T and per-step noise);
    imputation and guidance act while t ≥ ``stop_t`` (GMD: 20 of 1000), an ε model's x̂0 is
    clamped to ±``clip_x0`` (GMD: 6).

    ``models``: {"absolute": absolute-root trajectory model, "relative": relative-root one};
    a method's name starts with the short label of its model's representation;
    ``representations``: those whose methods run (both by default; an A/A control runs the
    reference arm's alone).
    *_imputation: :func:`abs_location_imputation` / :func:`rel_location_imputation`;
    *_guidance: :func:`location_loss` with strength s (GMD: 100).
    """
    runs: dict[str, ImputationRun] = {}
    for rep, label, imputation in (("absolute", "abs", abs_location_imputation),
                                   ("relative", "rel", rel_location_imputation)):
        if rep not in representations:
            continue
        trained = models[rep]
        frames = trained.spec.data.frames
        hooks = {f"{label}_unguided": {},
                 f"{label}_imputation": {"imputation": imputation(trained.space, task, frames)},
                 f"{label}_guidance": {"guidance": Guidance(location_loss(trained.space, task),
                                                            strength=strength)}}
        unguided_path = None
        for method, hook in hooks.items():
            x = sample(trained, task.n, seed=seed, stop_guidance_at=stop_t, clip_x0=clip_x0,
                       **hook)
            with torch.no_grad():
                path = trained.space.root_xz(x).cpu().numpy()
            if unguided_path is None:
                unguided_path = path
            change = np.linalg.norm(path - unguided_path, axis=-1)          # (n, T)
            away = np.ones(frames, dtype=bool)
            for frame in task.frames:
                away[max(frame - 2, 0):frame + 3] = False
            runs[method] = ImputationRun(
                method, x.cpu(), location_errors(trained.space, x, task),
                float(jitter_of(trained, x, part="root").acceleration),
                float(change.mean()), float(change[:, away].mean()))
    return runs


def registered_measurements(runs: dict[int, dict[str, ImputationRun]]) -> dict[str, list[float]]:
    """GMD-B2's measured values: per seed (in ``runs``' order) the mean location error (m) of
    each registered method, named ``<method>_error``, and the two names the rule also reads."""
    measured = {f"{method}_error": [per_seed[method].mean_error for per_seed in runs.values()]
                for method in REGISTERED_METHODS}
    # rel guidance vs abs imputation, under the two names the registered rule reads
    measured["rel_location_error"] = measured["rel_guidance_error"]
    measured["abs_location_error"] = measured["abs_imputation_error"]
    return measured


# --- GMD-B2: constructed samples with known location errors -------------------------------

#: E‖d‖ of d ~ N(0, σ²I₂) is σ·√(π/2): the σ that gives a mean location error r̄ is r̄/√(π/2)
_RAYLEIGH_MEAN = float(np.sqrt(np.pi / 2))


def b2_controls(test: MotionWindows, tasks: Mapping[int, Any], seeds: Sequence[int], *,
                mean_error: float = 0.1, abs_factor: float = 0.9) -> Controls:
    """GMD-B2's controls: constructed samples whose location errors are known, measured with
    the experiment's ``location_errors`` (mean over samples and the two target frames). A
    seed's sample set is a draw of test trajectories (as many as the seed's task has targets)
    with the root at the waypoint and goal frames placed at the target plus a Gaussian offset
    d ~ N(0, σ²I₂), σ = ``mean_error``/√(π/2), so E‖d‖ = ``mean_error``.

    Paired as the experiment (``impute_locations``: the four methods — imputation and
    guidance in each representation, ``REGISTERED_METHODS`` — sample the seed's task from the
    same x_T and per-step noise): one draw of trajectories and offsets per seed
    (:func:`control_seed` with arm 0; another draw per seed) is all four arms, toward the
    seed's targets. Null: every arm that draw (equal arms: log(rel / abs) = 0 in every seed).
    Positive: both abs arms' offsets × 0.9, so abs error = 0.9 × rel error exactly and
    log(rel / abs) = −log 0.9, the δ of both ratio parts, in every seed. The threshold part
    (0.1 m − abs imputation error, δ 1 cm) compares one arm with a constant: nothing pairs
    it, and it keeps the draw's own noise — the null's abs error is 0.1 m and the positive's
    0.09 m in expectation only. Tests plant larger effects through ``abs_factor``. The rule's
    two further names are filled as the experiment fills them (rel guidance, abs
    imputation)."""
    space = test.space("trajectory")
    sigma = mean_error / _RAYLEIGH_MEAN
    null: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    positive: dict[str, list[float]] = {f"{m}_error": [] for m in REGISTERED_METHODS}
    for s in seeds:
        task = tasks[s]
        frames = list(task.frames)
        x = test.trajectory()[draw_indices(test, task.n, control_seed(s, 0, stream=20))]
        offsets = sigma * np.random.default_rng(control_seed(s, 0, stream=21)).standard_normal(
            (task.n, len(frames), 2))
        for out, factor in ((null, 1.0), (positive, abs_factor)):
            for method in REGISTERED_METHODS:
                scale = factor if method.startswith("abs") else 1.0
                placed = located(space, x, frames, task.targets, scale * offsets)
                out[f"{method}_error"].append(float(location_errors(space, placed, task).mean()))
    for out in (null, positive):
        out["rel_location_error"] = out["rel_guidance_error"]
        out["abs_location_error"] = out["abs_imputation_error"]
    return Controls(null=null, positive=positive,
                    planted={"mean_location_error_m": mean_error, "abs_offset_factor": abs_factor},
                    null_text=(f"paired as the experiment: the same test trajectories, targets "
                               f"and Gaussian offsets (mean length {mean_error:g} m) in all four "
                               f"arms of a seed (another draw per seed), {len(seeds)} seed(s); "
                               f"no plant (equal arms; abs imputation at the 10 cm threshold in "
                               f"expectation, with its draw's own noise)"),
                    positive_text=(f"the same paired draws; both abs arms' offsets × "
                                   f"{abs_factor:g} (abs error {abs_factor:g} × rel's exactly; "
                                   f"mean {abs_factor * mean_error:.3g} m in expectation)"))


# ------------------------------------------------ the notebook's runs, gate records and result

def b2_runs(trajectory_models: Mapping[str, Mapping[int, TrainedGMD]], test: MotionWindows,
            seeds: Sequence[int], settings: Settings,
            ) -> tuple[dict[int, LocationTask], dict[int, dict[str, ImputationRun]]]:
    """Per seed, ``settings.targets`` waypoint + goal pairs from the relative-root ``test``
    windows (``location_task``) and every method of
    ``METHODS`` toward them (``impute_locations``: GMD's stop step and
    clamp), all from the seed's noise: (tasks, runs), each keyed by seed."""
    tasks, runs = {}, {}
    for s in seeds:
        tasks[s] = location_task(test, settings.targets, seed=s)
        models = {rep: trajectory_models[rep][s] for rep in REPRESENTATIONS}
        runs[s] = impute_locations(models, tasks[s], seed=s, stop_t=settings.guidance_stop_t,
                                   clip_x0=settings.x0_clamp)
    return tasks, runs


def b2_table_markdown(runs: Mapping[int, Mapping[str, ImputationRun]], seeds: Sequence[int],
                      targets: int, seconds: float) -> str:
    """Every method's errors and path changes, the mean over seeds."""
    columns = ["location_error", "waypoint_error", "goal_error", "root_acceleration",
               "path_change_off_target"]
    rows = []
    for method in METHODS:
        per_seed = [runs[s][method].summary() for s in seeds]
        rows.append([method] + [np.mean([p[c] for p in per_seed]) for c in columns])
    return (f"Mean over {len(seeds)} seeds × {targets} samples (sampling {seconds:.1f} s):\n\n"
            + markdown_table(["method", "location error (m)", "waypoint (m)", "goal (m)",
                              "root acceleration (m/s²)",
                              "path change ≥3 frames from the targets (m)"], rows))


def b2_model_records(trajectory_models: Mapping[str, Mapping[int, TrainedGMD]],
                     runs: Mapping[int, Mapping[str, ImputationRun]], windows: Windows,
                     seeds: Sequence[int]) -> list[dict[str, Any]]:
    """The trajectory models' ``gmd_trajectory`` gate records: held-out x̂0 error in their own
    representation and the path length of their unguided runs (same noise) against the test
    windows'. Every part of GMD-B2 rests on both representations' models (reads: None)."""
    reference = {rep: model_gates.trajectory_gate_values(
        windows[rep]["test"].space("trajectory"), windows[rep]["test"].trajectory())
        for rep in REPRESENTATIONS}
    return [model_gates.gmd_model_record(
        trajectory_models[rep][s], family="gmd_trajectory", reference=reference[rep],
        label=rep, role=REPRESENTATION_ROLES[rep], arm=rep,
        values={**model_gates.trajectory_gate_values(
            trajectory_models[rep][s], runs[s][f"{short_label(rep)}_unguided"].samples),
            **model_gates.denoising_gate_values(trajectory_models[rep][s],
                                                windows[rep]["test"], windows[rep]["train"],
                                                seed=s)})
        for rep in REPRESENTATIONS for s in seeds]


#: the registered threshold of GMD-B2's ``abs_imputation_below_10cm`` part (m)
B2_THRESHOLD = 0.1


#: GMD-B2's A/A slots: the abs (treatment) arms filled by the rel (reference) copy's errors;
#: the threshold part (0.1 m − abs imputation error) reads the copy's imputation error
B2_SLOTS = (Slot("abs_imputation_error", "rel_imputation_error", "imputation_error",
                 part="abs_imputes_better", sign=-1),
            Slot("abs_guidance_error", "rel_guidance_error", "guidance_error",
                 part="abs_guides_better", sign=-1))


def _b2_run_reading(runs: Mapping[str, ImputationRun]) -> dict[str, np.ndarray]:
    return {"imputation_error": runs["rel_imputation"].location_error.astype(np.float64),
            "guidance_error": runs["rel_guidance"].location_error.astype(np.float64)}


def b2_aa_readings(runs: Mapping[int, Mapping[str, ImputationRun]],
                   tasks: Mapping[int, LocationTask],
                   trajectory_models: Mapping[str, Mapping[int, TrainedGMD]],
                   test: MotionWindows, seeds: Sequence[int], settings: Settings) -> AAReadings:
    """GMD-B2's A/A runs (``controls.aa_readings``): the relative-root trajectory model (the
    reference arm) of seed s and its copy of the next seed, imputing and guiding toward seed
    s's targets from seed s's noise (per target and frame location errors); the own model's
    runs are the experiment's. A one-seed run's extra pairing draws its task from ``test``.

    The imputation errors are read by a ratio part (log rel / abs, blind to a common scale)
    and by a threshold part (0.1 m − abs): so both arms' imputation readings are scaled by one
    factor that puts the own models' mean at the 10 cm threshold (:data:`B2_THRESHOLD`), and
    the null sits at both parts' boundaries with the A/A's own spread (the positive's
    e^{−2δ} on the abs arm then moves the threshold part by ≈ 2δ: 0.1 m × (1 − 0.81))."""
    reference = dict(trajectory_models["relative"])

    def reading(model_seed: int, pairing_seed: int) -> dict[str, np.ndarray]:
        if model_seed == pairing_seed and model_seed in runs:
            return _b2_run_reading(runs[model_seed])
        task = (tasks[pairing_seed] if pairing_seed in tasks
                else location_task(test, settings.targets, seed=pairing_seed))
        return _b2_run_reading(impute_locations(
            {"relative": reference_model(reference, model_seed)}, task, seed=pairing_seed,
            stop_t=settings.guidance_stop_t, clip_x0=settings.x0_clamp,
            representations=("relative",)))

    found = aa_readings(reading, seeds)
    own = [float(np.mean(found.own[s]["imputation_error"])) for s, _ in found.pairs]
    scale = B2_THRESHOLD / float(np.mean(own)) if np.mean(own) > 0 else 1.0

    def at_threshold(reading: Mapping[int, Any]) -> dict[int, Any]:
        return {s: {**r, "imputation_error": np.asarray(r["imputation_error"]) * scale}
                for s, r in reading.items()}

    return AAReadings(found.pairs, at_threshold(found.own), at_threshold(found.copy))


def b2_result(runs: Mapping[int, Mapping[str, ImputationRun]],
              tasks: Mapping[int, LocationTask],
              trajectory_models: Mapping[str, Mapping[int, TrainedGMD]], test: MotionWindows,
              seeds: Sequence[int], settings: Settings, *, figures: Sequence[FigurePath],
              models: Sequence[Mapping[str, Any]]) -> ClaimResult:
    """GMD-B2: location error of imputation and of guidance in each representation, like for
    like, with its A/A controls (:func:`b2_aa_readings`: the relative-root model against an
    independently trained copy toward the same targets; the positive with 2δ planted)."""
    sampling = settings.sampling_parameters()
    measured = registered_measurements(dict(runs))
    summary = {m: {s: runs[s][m].summary() for s in seeds} for m in METHODS}
    mean = {m: float(np.mean(measured[f"{m}_error"])) for m in REGISTERED_METHODS}
    controls = aa_controls("GMD-B2", b2_aa_readings(runs, tasks, trajectory_models, test,
                                                    seeds, settings),
                           B2_SLOTS, reference_arm="relative-root trajectory")
    for out in (controls.null, controls.positive):   # the rule's two further names
        out["rel_location_error"] = out["rel_guidance_error"]
        out["abs_location_error"] = out["abs_imputation_error"]
    first = seeds[0]
    return ClaimResult(
        "GMD-B2", measured, seeds=seeds, settings=rule_settings.b2(settings),
        figures=list(figures), controls=controls, models=list(models),
        headline=(f"imputation: abs {mean['abs_imputation']:.3f} m vs rel "
                  f"{mean['rel_imputation']:.3f} m; guidance: abs {mean['abs_guidance']:.3f} "
                  f"m vs rel {mean['rel_guidance']:.3f} m ({len(seeds)} seeds × "
                  f"{settings.targets} samples, T = {sampling['num_timesteps']}, stop t = "
                  f"{sampling['guidance_stop_t']})"),
        notes=("Like for like: abs imputation (x/z entries of the two target frames replaced) "
               "vs rel imputation (root rotation and velocity of every frame replaced by the "
               "straight forward-facing path through both targets), and the same L1 goal "
               "guidance (s = 100) in both. Imputation and guidance act while t ≥ "
               f"{sampling['guidance_stop_t']} of T = {sampling['num_timesteps']}; ε model "
               f"x̂0 clamped to ±{sampling['x0_clamp']:g}. Model: "
               + describe(trajectory_models["absolute"][first].spec) + "; targets from test "
               f"windows (waypoint frame {tasks[first].waypoint_frame}, goal frame "
               f"{tasks[first].goal_frame})."),
        extra={"parameters": sampling, "per_method": summary,
               "controls_planted": controls.planted})


# -------------------------------------------------------------------- reading and figures

def reading_b2(per_method: dict[str, list[dict[str, float]]], *, seeds: Sequence[int],
               stop_t: int) -> str:
    """GMD-B2: imputation against imputation, guidance against guidance, and what each route
    costs. ``per_method[method]``: ``ImputationRun.summary()`` per seed; ``stop_t``: the step
    after which neither mechanism acts."""
    def values(method: str, key: str = "location_error") -> list[float]:
        return [row[key] for row in per_method[method]]

    def mean(method: str, key: str = "location_error") -> float:
        return float(np.mean(values(method, key)))

    imputation_better = count_below(values("abs_imputation"), values("rel_imputation"))
    guidance_better = count_below(values("abs_guidance"), values("rel_guidance"))
    abs_guidance_helps = mean("abs_guidance") < mean("abs_unguided")
    rel_guidance_helps = mean("rel_guidance") < mean("rel_unguided")
    return render(
        "**Reading** (this run, seeds {seeds}). *Imputation against imputation:* replacing "
        "the two x/z entries in abs ends {abs_imp} m from the targets, replacing the root "
        "entries of every frame in rel {rel_imp} m (abs closer on {ki} of {n} seeds). "
        "{free} The rel imputation dictates the whole root path (every frame's entries are "
        "replaced); against the unguided samples of the same noise it moves the path "
        "{rel_off:.3f} m on frames away from the targets, abs imputation {abs_off:.3f} m. "
        "*Guidance against "
        "guidance:* abs ends {abs_g} m, rel {rel_g} m from the targets (abs closer on {kg} of "
        "{n} seeds); against the unguided samples guidance {abs_help} in abs ({abs_u} m "
        "unguided) and {rel_help} in rel ({rel_u} m).",
        seeds=list(seeds), abs_imp=interval_text(values("abs_imputation")),
        rel_imp=interval_text(values("rel_imputation")), ki=imputation_better, n=len(seeds),
        free=either(stop_t > 0, render(
            "Both replacements hold the targets while t ≥ {stop}; what the last {stop} free "
            "steps move in rel is summed over every earlier frame, in abs it is the entry "
            "itself.", stop=stop_t), "Both replacements act to the last step (t = 0), so both "
            "end on their targets up to rounding."),
        rel_off=mean("rel_imputation", "path_change_off_target"),
        abs_off=mean("abs_imputation", "path_change_off_target"),
        abs_g=interval_text(values("abs_guidance")), rel_g=interval_text(values("rel_guidance")),
        kg=guidance_better, abs_help=either(abs_guidance_helps, "helped", "did not help"),
        rel_help=either(rel_guidance_helps, "helped", "did not help"),
        abs_u=interval_text(values("abs_unguided")), rel_u=interval_text(values("rel_unguided")))


def plot_imputation(models: dict[str, TrainedGMD], runs: dict[str, ImputationRun],
                    task: LocationTask, samples: int = 4) -> Figure:
    """Top-down root paths of a few samples of every method, the targets marked."""
    import matplotlib.pyplot as plt

    by_short_label = {short_label(rep): rep for rep in models}
    fig, axes = plt.subplots(2, 3, figsize=(13, 8.5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, method in zip(axes.ravel(), METHODS, strict=True):
        trained = models[by_short_label[method.split("_")[0]]]
        with torch.no_grad():
            paths = trained.space.root_xz(runs[method].samples[:samples]).numpy()
        for k, path in enumerate(paths):
            colour = colours[k % len(colours)]
            ax.plot(path[:, 0], path[:, 1], "-", color=colour, lw=1.3)
            ax.plot(*path[task.waypoint_frame], "o", color=colour, ms=4)
            ax.plot(*path[-1], ">", color=colour, ms=5)
            for target, marker in zip(task.targets[k], ("x", "*"), strict=True):
                ax.plot(*target, marker, color=colour, ms=10, mew=2)
        error = runs[method].mean_error
        ax.set_title(f"{method.replace('_', ' ')}: error {error:.3f} m", fontsize=9)
        ax.set_aspect("equal", adjustable="datalim")
    for ax in axes[-1]:
        ax.set_xlabel("x (m)")
    for ax in axes[:, 0]:
        ax.set_ylabel("z (m)")
    fig.suptitle(f"waypoint (×, frame {task.waypoint_frame}) and goal (*, last frame); "
                 "dots/arrows: where the samples are at those frames", fontsize=10)
    fig.tight_layout()
    return fig


def plot_method_errors(per_seed: dict[str, list[float]], ylabel: str, title: str) -> Figure:
    """Per-method bars (mean over seeds) with every seed's value as a dot."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6))
    names = list(per_seed)
    for i, name in enumerate(names):
        values = np.asarray(per_seed[name])
        ax.bar(i, values.mean(), color="tab:blue" if name.startswith("abs") else "tab:red",
               alpha=0.6)
        ax.plot(np.full(len(values), i), values, "k.", ms=6)
    ax.set_xticks(range(len(names)), [n.replace("_", "\n") for n in names], fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_yscale("log")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig
