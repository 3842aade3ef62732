"""The run settings of the GMD claims: seeds per scale, what each rule quotes, the scale note.

- ``FULL_SEEDS`` / ``STANDARD_SEEDS`` / ``QUICK_SEEDS`` (:func:`seeds_of`): how many seeds each
  claim's experiment runs, per scale — the one table;
- ``STANDARD_NOT_RUN`` (:func:`not_run`): the parts the standard scale does not run, each with
  why — registered before the run that uses it, so a verdict says what the scale cannot decide;
- :func:`a3` … :func:`f1` (``RULE_SETTINGS``): what each claim's rule quotes of its run, read
  from the ``Settings`` object its experiment used, never typed;
- :func:`scale_note`: what a notebook's reader must know about its run's scale.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from repro.gmd.guidance import GMD_CFG_SCALE, GMD_GUIDANCE_STRENGTH, default_stop_step
from repro.gmd.models import (
    GUIDANCE_DIFFUSION_STEPS,
    MOTION_ARCHITECTURE,
    STANDARD_DIFFUSION_STEPS,
    STANDARD_MOTION_ARCHITECTURE,
    STANDARD_MOTION_TRAINING,
    STANDARD_TRAJECTORY_ARCHITECTURE,
    STANDARD_TRAJECTORY_TRAINING,
    TRAJECTORY_ARCHITECTURE,
    X0_CLAMP,
    Architecture,
)
from repro.infra.context import QUICK_NOTE

__all__ = ["FULL_SEEDS", "QUICK_SEEDS", "RULE_SETTINGS", "STANDARD_C4_TRAIN_STEPS",
           "STANDARD_NOT_RUN", "STANDARD_SEEDS", "a3", "a4", "b2", "b3", "c4", "f1",
           "not_run", "scale_note", "seeds_of"]



# ------------------------------------------------------------------------------------------------
# How many seeds each GMD claim's experiment runs, per scale: the one table.
#
# The registry plans no seed count from an earlier run's spread: a run uses the seeds its
# budget affords, and each part states from its own interval what it could have seen
# (``claims.power.minimum_detectable_effect``). Notebook 01's A3 and A4 share one seed list
# (the same trajectory models), as do F1's trajectory and motion models. The paper scale runs
# ``FULL_SEEDS`` (the registered full settings), the standard scale 3 for every claim
# (docs/COMPUTE.md §3a item 5), quick runs one. GMD-C4's standard run trains both matched values
# (k = 2 and k = 10, each with its Emphasis arm) on 3 seeds at ``STANDARD_C4_TRAIN_STEPS`` (its
# arms pass their gate from 1500 steps, docs/COMPUTE.md §13): 12 models, so its parts and its
# A/A null control (seed s's reference arm against seed s + 1's) have a spread between models.
# ------------------------------------------------------------------------------------------------

#: the paper scale's seeds (today's registered full settings)
FULL_SEEDS: dict[str, int] = {
    "GMD-A3": 3, "GMD-A4": 3,   # notebook 01: two trajectory + motion models per seed
    "GMD-B2": 3,                # notebook 02: two trajectory models, six methods at T = 1000
    "GMD-B3": 5,                # notebook 02: two motion models per seed
    "GMD-C4": 6,                # notebook 03: two values × two arms per seed (24 models)
    "GMD-F1": 3,                # notebook 06
}


#: the standard scale's seeds: 3 for every GMD claim (GMD-C4's arms at 1500 steps)
STANDARD_SEEDS: dict[str, int] = dict.fromkeys(FULL_SEEDS, 3)


QUICK_SEEDS = 1


def seeds_of(claim_id: str, scale: str) -> int:
    """The seeds ``claim_id``'s experiment runs at ``scale``, a scale its notebook's settings
    constructor checked (quick, standard or paper; any other is a KeyError)."""
    if claim_id not in FULL_SEEDS:
        raise ValueError(f"no seed count for {claim_id!r}; have {sorted(FULL_SEEDS)}")
    return {"quick": QUICK_SEEDS, "standard": STANDARD_SEEDS[claim_id],
            "paper": FULL_SEEDS[claim_id]}[scale]



# --- GMD-C4's standard-scale training steps ------------------------------------------------------

#: the standard scale's training steps of GMD-C4's arms (docs/COMPUTE.md §9, §13): the k = 10
#: and Gaussian c = 10 arms of seed 0 pass their x̂0 gate (≤ 0.9) from 1500 steps (0.856 and
#: 0.787; 0.952 and 0.850 at 1200, 1.12 and 0.94 at the other motion models' 900)
STANDARD_C4_TRAIN_STEPS = 1500



# ------------------------------------------------------------------------------------------------
# What the standard scale does not run, each a statement of what the scale cannot decide,
# fixed before the run that uses it (docs/COMPUTE.md §16, §21).
#
# A part is cut for what it reads or for the budget, with its cost: B3's parts read the motion
# evaluator, which no design piloted within the budget passes (blind to frame order); F1's
# second stage is cut for its CPU-minutes (its model, shared by both stop arms, would gate
# nothing under gates version 5). A treatment arm is never cut on its expected outcome:
# GMD-A4's ε motion arm, which the claim predicts learns worse, runs at standard with the x0
# motion arm's spec and steps (width 64, the standard design; GMD's widths are the paper
# scale's). The quick scale runs every part (a test of the code); the paper scale decides the
# cut ones.
# ------------------------------------------------------------------------------------------------

_B3_EVALUATOR = (
    "no motion model is trained for it: every part reads the motion evaluator, and no "
    "evaluator piloted within the standard budget passes its gate — it is nearly blind to "
    "frame order (shuffled frames score 1.2–1.9× the real windows' FID against a bound of 3×, "
    "with convolutional or recurrent encoders, 500 or 3000 steps; docs/COMPUTE.md §15). The "
    "paper scale decides it")

_F1_SECOND_STAGE = (
    "cut for the budget: GMD's second stage needs its own absolute-root x0 motion models, "
    "3 × 4500 steps ≈ 19 CPU-minutes of training on the Intel without AMX (375 s each, as the "
    "x0 motion models of docs/COMPUTE.md §20a) and ≈ 3 CPU-minutes of guided sampling, which "
    "would take the standard run past its 75 minutes on Zen 4 (≈ 67 without them, §21). Both "
    "stop arms would sample the same model, so its gates would not hold the part back (gates "
    "version 5); its samples were jagged at this width (joint jerk 14–23× the windows', §15a). "
    "The paper scale decides it")

#: claim → part → why the standard scale does not run it
STANDARD_NOT_RUN: dict[str, dict[str, str]] = {
    "GMD-B3": dict.fromkeys(("abs_lower_fid", "abs_diversity_closer_to_real",
                             "abs_r_precision_not_worse"), _B3_EVALUATOR),
    "GMD-F1": {"stop_at_20_more_coherent": _F1_SECOND_STAGE},
}


def not_run(claim_id: str, scale: str) -> dict[str, str]:
    """The parts of ``claim_id`` that ``scale`` does not run, each with why (``{}``: every
    part runs; any scale but quick, standard or paper is a KeyError); ``ClaimResult.not_run``
    takes it."""
    if claim_id not in FULL_SEEDS:
        raise ValueError(f"no GMD claim {claim_id!r}; have {sorted(FULL_SEEDS)}")
    return {"quick": {}, "standard": dict(STANDARD_NOT_RUN.get(claim_id, {})),
            "paper": {}}[scale]



# ------------------------------------------------------------------------------------------------
# What a GMD notebook's reader must know about its run's scale, rendered from the settings.
#
# The notebooks' design text describes GMD's own settings (T = 1000, its widths, the registered
# seed counts): the paper scale. A standard run (``make reproduce``) uses the tiny design of
# docs/COMPUTE.md; :func:`scale_note` says which, from the constants the code runs with.
# ------------------------------------------------------------------------------------------------

def _widths(architecture: Architecture) -> str:
    mults = ", ".join(f"{m:g}" for m in architecture.channel_mults)
    return f"{architecture.base_channels} × ({mults})"


def scale_note(scale: str) -> str:
    """A markdown line for the top of a GMD notebook: the run's scale and, at standard, how
    its models and diffusion differ from the paper settings the design text names (any scale
    but quick, standard or paper is a KeyError)."""
    return {"quick": lambda: QUICK_NOTE, "standard": _standard_note,
            "paper": _paper_note}[scale]()


def _paper_note() -> str:
    """The paper scale's line: GMD's settings as the design text states them."""
    return ("**Paper scale**: GMD's settings as the design text states them "
            f"(T = {GUIDANCE_DIFFUSION_STEPS} for guidance, motion UNet "
            f"{_widths(MOTION_ARCHITECTURE)}, trajectory UNet "
            f"{_widths(TRAJECTORY_ARCHITECTURE)}, the registered seed counts).")


def _standard_note() -> str:
    """The standard scale's line: its T, widths, steps, seeds and the parts it does not run."""
    seeds = ", ".join(f"{claim} {n}" for claim, n in STANDARD_SEEDS.items())
    cuts = "; ".join(f"{claim} ({', '.join(parts)})" for claim, parts in STANDARD_NOT_RUN.items())
    return (f"**Standard scale** (`make reproduce`, docs/COMPUTE.md): every GMD model has "
            f"T = {STANDARD_DIFFUSION_STEPS} (guidance stop steps at the same fraction of T "
            f"as GMD's 20 of {GUIDANCE_DIFFUSION_STEPS}); motion UNet "
            f"{_widths(STANDARD_MOTION_ARCHITECTURE)}, "
            f"{STANDARD_MOTION_TRAINING.step_cap} steps (GMD-C4's arms "
            f"{STANDARD_C4_TRAIN_STEPS}); trajectory UNet "
            f"{_widths(STANDARD_TRAJECTORY_ARCHITECTURE)}, "
            f"{STANDARD_TRAJECTORY_TRAINING.step_cap} steps; seeds per claim: {seeds}. "
            f"GMD-A4 compares its x0 and ε motion arms at width "
            f"{STANDARD_MOTION_ARCHITECTURE.base_channels} (both the standard motion UNet and "
            "steps). "
            f"Not run at this scale (each part says why): {cuts}. "
            "Where the text below names GMD's T = 1000, its widths or more "
            "seeds, those are the paper scale's; the values this run used are printed by its "
            "cells and recorded in every claim's sidecar.")



# ------------------------------------------------------------------------------------------------
# What each GMD claim's rule quotes of its run, read from the settings object
# its experiment used — never typed.
#
# A registered rule is a template (``claims.claim.Claim.rule_fields``); the run's values go in
# when the claim is recorded (``ClaimResult.settings``). Each function here takes the
# experiment's own ``Settings`` (``x0_vs_eps``, ``root_representation``, ``emphasis_projection``,
# ``guidance_schedule``) and returns every field its claim's template names: the diffusion
# steps T of the models the rule compares, the guidance stop step (GMD's t = 20 of T = 1000,
# at another T the same fraction, ``guidance.default_stop_step``), the guidance strength, the
# x̂0 clamp, the seeds and the items (goals, targets, samples). ``tests/claims/
# test_rule_settings.py`` renders every rule at every scale from these.
# ------------------------------------------------------------------------------------------------

def a3(settings: Any) -> dict[str, Any]:
    """GMD-A3: the guidance trajectory models' T, GMD's stop step at that T and strength (the
    defaults ``x0_vs_eps.goal_reaching.goal_reaching_experiment`` runs with), the ε model's
    clamp (GMD's, ``clip_x0="gmd"``), goals per seed."""
    steps = settings.guidance_diffusion_steps
    return {"seeds": settings.seeds, "goals": settings.goals, "T": steps,
            "strength": GMD_GUIDANCE_STRENGTH, "stop_step": default_stop_step(steps),
            "x0_clamp": X0_CLAMP}


def a4(settings: Any) -> dict[str, Any]:
    """GMD-A4: the motion and trajectory models' T and the unguided samples per seed."""
    return {"seeds": settings.seeds, "samples": settings.generated,
            "T": settings.diffusion_steps}


def b2(settings: Any) -> dict[str, Any]:
    """GMD-B2: the trajectory models' T, the stop step imputation and guidance act down to,
    the strength (``root_representation.b2.impute_locations``' default), the clamp, targets."""
    return {"seeds": settings.seeds, "targets": settings.targets,
            "T": settings.trajectory_diffusion_steps, "stop_step": settings.guidance_stop_t,
            "strength": GMD_GUIDANCE_STRENGTH, "x0_clamp": settings.x0_clamp}


def b3(settings: Any) -> dict[str, Any]:
    """GMD-B3: the motion models' T, one sample per evaluation window, GMD's CFG scale."""
    return {"seeds": settings.motion_seeds, "samples": settings.evaluation_windows,
            "T": settings.diffusion_steps, "cfg_scale": GMD_CFG_SCALE}


def c4(settings: Any) -> dict[str, Any]:
    """GMD-C4: the matched values this scale trains, T, samples per arm."""
    return {"seeds": settings.seeds, "values": settings.values, "T": settings.diffusion_steps,
            "samples": settings.samples}


def f1(settings: Any) -> dict[str, Any]:
    """GMD-F1: the trajectory model's T, the model's stop step for GMD's t = 20, GMD's s at
    which the stops are compared, the strengths the rule reads, goals per seed."""
    return {"seeds": settings.seeds, "goals": settings.goals, "T": settings.num_timesteps,
            "stop_step": settings.stops()[settings.gmd_stop], "strength": settings.gmd_strength,
            "strengths": settings.rule_strengths}


#: claim → the function giving what its rule quotes, from its experiment's settings
RULE_SETTINGS: dict[str, Callable[[Any], dict[str, Any]]] = {
    "GMD-A3": a3, "GMD-A4": a4, "GMD-B2": b2, "GMD-B3": b3, "GMD-C4": c4, "GMD-F1": f1}
