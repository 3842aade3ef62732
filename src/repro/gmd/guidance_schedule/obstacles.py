"""Notebook 06's obstacle extra (outside GMD-F1's rule): goal reaching past one circular
obstacle per goal, GMD's obstacle task (appendix F: no point-to-point imputation, which could
lead through an obstacle) against the imputed straight line.

- per-sample circular obstacles: a hinge cost, penetration depth, collisions, and the sampler
  of every arm in one call (``obstacle_experiment``);
- the study over the seeds (``obstacle_study``): at GMD's s and at the strength of the sweep
  with the lowest mean goal error.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from repro.gmd.guidance import Clamp, goal_error, goal_reaching_loss, sample
from repro.gmd.guidance_schedule.experiment import ScheduleModels, Sweeps
from repro.gmd.guidance_schedule.sampling import (
    point_to_point_imputation,
    shared_start_noise,
    strength_key,
    weighted_guidance,
)
from repro.gmd.guidance_schedule.settings import Settings
from repro.gmd.measurements import jitter_of
from repro.gmd.models import TrainedGMD
from repro.gmd.windows import FeatureSpace

__all__ = ["ObstacleArm", "ObstacleSet", "ObstacleStudy", "obstacle_cost", "obstacle_experiment",
           "obstacle_study", "obstacles_between", "penetration_depth"]

# --- the obstacles and their sampler -----------------------------------------------------------

@dataclass(frozen=True)
class ObstacleSet:
    """One circular obstacle per sample: ``centres`` (B, 2) world x/z and ``radii`` (B,), m."""

    centres: np.ndarray
    radii: np.ndarray

    def __post_init__(self) -> None:
        if self.centres.shape != (len(self.radii), 2):
            raise ValueError(f"centres {self.centres.shape} and radii {self.radii.shape} "
                             "must be (B, 2) and (B,)")

    def tile(self, groups: int) -> ObstacleSet:
        """The same obstacles for ``groups`` consecutive groups of samples."""
        return ObstacleSet(np.tile(self.centres, (groups, 1)), np.tile(self.radii, groups))


def obstacles_between(targets_xz: np.ndarray, *, position: float = 0.5,
                      radius_fraction: float = 0.3, max_radius: float = 0.4) -> ObstacleSet:
    """An obstacle on the straight line from the start (origin) to each goal, at ``position``
    of the way, radius min(``max_radius``, ``radius_fraction``·‖goal‖). With the defaults the
    start and the goal are ≥ 0.2·‖goal‖ outside the circle: it blocks the straight path but
    can be walked around."""
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    distance = np.linalg.norm(targets, axis=1)
    radii = np.minimum(max_radius, radius_fraction * distance).astype(np.float32)
    return ObstacleSet((position * targets).astype(np.float32), radii)


def _signed_clearance(space: FeatureSpace, x: Tensor, obstacles: ObstacleSet) -> Tensor:
    """‖p_xz(t) − c‖ − r (B, T): negative inside the sample's obstacle."""
    position = space.root_xz(x)                                            # (B, T, 2)
    centres = torch.as_tensor(obstacles.centres, dtype=position.dtype, device=position.device)
    radii = torch.as_tensor(obstacles.radii, dtype=position.dtype, device=position.device)
    if len(centres) != len(position):
        raise ValueError(f"{len(centres)} obstacles for {len(position)} samples")
    return (position - centres[:, None, :]).norm(dim=-1) - radii[:, None]


def obstacle_cost(space: FeatureSpace, obstacles: ObstacleSet) -> Callable[[Tensor], Tensor]:
    """G_obs(x̂0) = Σ_t max(0, r − ‖p_xz(t) − c‖) per sample (m): the penetration of the root
    path into its own obstacle, summed over frames (the hinge of ``obstacle_loss``, one
    obstacle per sample)."""

    def cost(pred_x0: Tensor) -> Tensor:
        return torch.relu(-_signed_clearance(space, pred_x0, obstacles)).sum(dim=1)

    return cost


def penetration_depth(space: FeatureSpace, x: Tensor, obstacles: ObstacleSet) -> np.ndarray:
    """The deepest point of each root path inside its obstacle, max_t max(0, r − ‖p − c‖)
    (B,) in metres; > 0 means a collision."""
    with torch.no_grad():
        clearance = _signed_clearance(space, x.detach(), obstacles)
    return torch.relu(-clearance).amax(dim=1).cpu().numpy()


@dataclass
class ObstacleArm:
    """One arm of ``obstacle_experiment``: n samples toward the goals past the obstacles."""

    label: str
    strength: float
    obstacle_weight: float
    point_to_point: bool
    samples: Tensor
    goal_error: np.ndarray
    penetration: np.ndarray
    jerk: float

    @property
    def collision_rate(self) -> float:
        """Fraction of samples whose root path enters its obstacle."""
        return float(np.mean(self.penetration > 0.0))


def obstacle_experiment(trained: TrainedGMD, targets_xz: np.ndarray,
                        obstacles: ObstacleSet, strengths: Sequence[float], *, seed: int,
                        stop: int, obstacle_weight: float = 1.0,
                        frame: int = -1, clip_x0: Clamp = "gmd") -> list[ObstacleArm]:
    """Goal reaching past one obstacle per goal, in one sampling call (same x_T for all arms):

    - "unguided";
    - per strength s: "goal" (goal guidance only), "goal + obstacle" (guidance on
      G = G_goal + ``obstacle_weight``·G_obs, no imputation: GMD's obstacle task) and
      "goal + obstacle + p2p" (the same plus the straight start→goal line imputed, which GMD
      avoids because the line can cross the obstacle).

    Guidance and imputation act while t ≥ ``stop``; ``clip_x0`` as in ``sweep_strengths``.
    """
    targets = np.asarray(targets_xz, dtype=np.float32).reshape(-1, 2)
    n = len(targets)
    plan = [("unguided", 0.0, 0.0, False)]
    for s in strengths:
        plan += [(f"goal, s={strength_key(s)}", float(s), 0.0, False),
                 (f"goal + obstacle, s={strength_key(s)}", float(s), obstacle_weight, False),
                 (f"goal + obstacle + p2p, s={strength_key(s)}", float(s), obstacle_weight,
                  True)]
    groups = len(plan)
    all_targets = np.tile(targets, (groups, 1))
    all_obstacles = obstacles.tile(groups)
    strength = torch.as_tensor(np.repeat([p[1] for p in plan], n), dtype=torch.float32)
    weight = torch.as_tensor(np.repeat([p[2] for p in plan], n), dtype=torch.float32)
    goal = goal_reaching_loss(trained.space, all_targets, frame)
    avoid = obstacle_cost(trained.space, all_obstacles)

    def combined(pred_x0: Tensor) -> Tensor:
        w = weight.to(pred_x0.device, pred_x0.dtype)
        return goal(pred_x0) + w * avoid(pred_x0)

    imputation = point_to_point_imputation(trained, all_targets,
                                           active=np.repeat([p[3] for p in plan], n))
    x = sample(trained, n * groups, seed=seed, guidance=weighted_guidance(combined, strength),
               imputation=imputation, stop_guidance_at=stop, clip_x0=clip_x0,
               noise=shared_start_noise(trained, n, groups, seed=seed)).cpu()
    error = goal_error(trained.space, x, all_targets, frame).reshape(groups, n)
    depth = penetration_depth(trained.space, x, all_obstacles).reshape(groups, n)
    samples = x.reshape(groups, n, *x.shape[1:])
    return [ObstacleArm(label, s, w, p2p, samples[g], error[g], depth[g],
                        float(jitter_of(trained.space, samples[g]).jerk))
            for g, (label, s, w, p2p) in enumerate(plan)]


# --- the study over the seeds ----------------------------------------------------------------

@dataclass
class ObstacleStudy:
    """The obstacle extra (outside the rule): the sweep's strength with the lowest mean goal
    error (``s_lowest``, from ``sweep_goal_mean``), the strengths run, per seed the obstacles
    and the arms, and per arm label the per-seed collision rate, penetration, goal error and
    root jerk (``summary``)."""

    sweep_goal_mean: dict[int, float]
    s_lowest: int
    strengths: list[int]
    sets: dict[int, ObstacleSet]
    runs: dict[int, list[ObstacleArm]]
    summary: dict[str, dict[str, list[float]]]

    def table(self) -> str:
        """Each arm's collisions per seed, mean penetration, goal error and root jerk."""
        rows = ["| arm | collisions, per seed | mean penetration (m) | goal error (m) | root "
                "jerk (m/s³) |", "|---|---|---|---|---|"]
        for label, m in self.summary.items():
            rows.append(f"| {label} | {', '.join(f'{c:.2f}' for c in m['collision_rate'])} | "
                        f"{np.mean(m['penetration_m']):.3f} | {np.mean(m['goal_error_m']):.2f} | "
                        f"{np.mean(m['root_jerk']):.4g} |")
        return "\n".join(rows)


def obstacle_study(m: ScheduleModels, sweeps: Sweeps, settings: Settings) -> ObstacleStudy:
    """:func:`obstacle_experiment` per seed on the first
    ``settings.obstacle_goals`` goals, one obstacle each (``obstacles_between``), at GMD's s and
    at the guided strength with the lowest mean goal error of the sweep."""
    sweep_goal_mean = {v: float(np.mean(sweeps.goal_by_s[strength_key(v)]))
                       for v in settings.strengths if v > 0}
    s_lowest = min(sweep_goal_mean, key=sweep_goal_mean.get)
    strengths = sorted({settings.gmd_strength, s_lowest})
    runs, sets = {}, {}
    for s in sweeps.seeds:
        goals = sweeps.targets[s][:settings.obstacle_goals]
        sets[s] = obstacles_between(goals)
        runs[s] = obstacle_experiment(m.models[s], goals, sets[s], strengths, seed=s,
                                      stop=m.stops[settings.gmd_stop],
                                      obstacle_weight=settings.obstacle_weight)
    per_seed = sweeps.per_seed
    summary = {label: {
        "collision_rate": per_seed(lambda s, i=i: runs[s][i].collision_rate),
        "penetration_m": per_seed(lambda s, i=i: runs[s][i].penetration.mean()),
        "goal_error_m": per_seed(lambda s, i=i: runs[s][i].goal_error.mean()),
        "root_jerk": per_seed(lambda s, i=i: runs[s][i].jerk)}
        for i, label in enumerate(arm.label for arm in runs[sweeps.seeds[0]])}
    return ObstacleStudy(sweep_goal_mean, s_lowest, strengths, sets, runs, summary)
