"""What each GMD claim's rule quotes of its run (registry v5), read from the settings object
its experiment used — never typed.

A registered rule is a template (``claims.claim.Claim.rule_fields``); the run's values go in
when the claim is recorded (``ClaimResult.settings``). Each function here takes the
experiment's own ``Settings`` (``x0_vs_eps``, ``root_representation``, ``emphasis_study``,
``guidance_schedule``) and returns every field its claim's template names: the diffusion
steps T of the models the rule compares, the guidance stop step (GMD's t = 20 of T = 1000,
at another T the same fraction, ``guidance.default_stop_step``), the guidance strength, the
x̂0 clamp, the seeds and the items (goals, targets, samples). ``tests/gmd/
test_rule_settings.py`` renders every rule at every scale from these.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from repro.gmd.cfg import GMD_CFG_SCALE
from repro.gmd.guidance import GMD_GUIDANCE_STRENGTH, default_stop_step
from repro.gmd.paper_settings import X0_CLAMP

if TYPE_CHECKING:
    from repro.gmd import emphasis_study, guidance_schedule, root_representation, x0_vs_eps

__all__ = ["RULE_SETTINGS", "a3", "a4", "b2", "b3", "c4", "f1"]


def a3(settings: x0_vs_eps.Settings) -> dict[str, Any]:
    """GMD-A3: the guidance trajectory models' T, GMD's stop step at that T and strength (the
    defaults ``x0_vs_eps.goal_reaching_experiment`` runs with), the ε model's clamp (GMD's,
    ``clip_x0="gmd"``), goals per seed."""
    steps = settings.guidance_diffusion_steps
    return {"seeds": settings.seeds, "goals": settings.goals, "T": steps,
            "strength": GMD_GUIDANCE_STRENGTH, "stop_step": default_stop_step(steps),
            "x0_clamp": X0_CLAMP}


def a4(settings: x0_vs_eps.Settings) -> dict[str, Any]:
    """GMD-A4: the motion and trajectory models' T and the unguided samples per seed."""
    return {"seeds": settings.seeds, "samples": settings.generated,
            "T": settings.diffusion_steps}


def b2(settings: root_representation.Settings) -> dict[str, Any]:
    """GMD-B2: the trajectory models' T, the stop step imputation and guidance act down to,
    the strength (``location_imputation.impute_locations``' default), the clamp, targets."""
    return {"seeds": settings.seeds, "targets": settings.targets,
            "T": settings.trajectory_diffusion_steps, "stop_step": settings.guidance_stop_t,
            "strength": GMD_GUIDANCE_STRENGTH, "x0_clamp": settings.x0_clamp}


def b3(settings: root_representation.Settings) -> dict[str, Any]:
    """GMD-B3: the motion models' T, one sample per evaluation window, GMD's CFG scale."""
    return {"seeds": settings.motion_seeds, "samples": settings.evaluation_windows,
            "T": settings.diffusion_steps, "cfg_scale": GMD_CFG_SCALE}


def c4(settings: emphasis_study.Settings) -> dict[str, Any]:
    """GMD-C4: the matched values this scale trains, T, samples per arm."""
    return {"seeds": settings.seeds, "values": settings.values, "T": settings.diffusion_steps,
            "samples": settings.samples}


def f1(settings: guidance_schedule.Settings) -> dict[str, Any]:
    """GMD-F1: the trajectory model's T, the model's stop step for GMD's t = 20, GMD's s at
    which the stops are compared, the strengths the rule reads, goals per seed."""
    return {"seeds": settings.seeds, "goals": settings.goals, "T": settings.num_timesteps,
            "stop_step": settings.stops()[settings.gmd_stop], "strength": settings.gmd_strength,
            "strengths": settings.rule_strengths}


#: claim → the function giving what its rule quotes, from its experiment's settings
RULE_SETTINGS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "GMD-A3": a3, "GMD-A4": a4, "GMD-B2": b2, "GMD-B3": b3, "GMD-C4": c4, "GMD-F1": f1}
