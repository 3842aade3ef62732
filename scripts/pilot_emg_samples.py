"""Pilot: do the EnergyMoGen pipeline's reference models pass gates version 4's sample gates?

Loads (training on a miss) the standard scale's pipeline of one training seed, exactly as
notebooks 04 and 05 do (``config.pipeline_config``, the scale's ``TrainingPlan``), and
measures on notebook 07's held-out text-to-motion test set what the ``vae`` and
``latent_denoiser`` records measure in the reference role (``model_gates.pipeline_records``):
reconstructions' jerk and foot skating, decoded samples' speeds, jerk, skating and concept
recall, each against the test clips. One JSON line goes to ``--out``::

    PYTHONPATH=src python scripts/pilot_emg_samples.py --scale standard --seed 0 \\
        --out pilots/emg_samples.jsonl

``--kl`` (the VAE's KL weight), ``--vae-lr-schedule``, ``--denoiser-width``,
``--denoiser-steps`` and ``--denoiser-lr`` change the scale's pipeline for a design pilot
(the row records them; the rows with ``fixed_gait`` true in pilots/emg_denoiser_latent.jsonl
were made by this script at ce0b091, before ``settings.GAIT_RHYTHM`` was the stand-in's).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import torch

from repro.core.train_config import LR_SCHEDULES
from repro.energymogen import model_gates
from repro.energymogen.energy_contour_maps import EnergyViewSettings
from repro.energymogen.harness import load_or_build_text_to_motion_test
from repro.energymogen.latent_count.emg7 import LatentCountSettings
from repro.energymogen.pipeline import SeedPipelines, load_pipeline
from repro.energymogen.settings import pipeline_config
from repro.infra.context import SCALES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scale", choices=SCALES, default="standard")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--label", default="standard pipeline")
    parser.add_argument("--kl", type=float, default=None, help="the VAE's KL weight")
    parser.add_argument("--vae-lr-schedule", choices=LR_SCHEDULES, default=None)
    parser.add_argument("--denoiser-width", type=int, default=None)
    parser.add_argument("--denoiser-steps", type=int, default=None)
    parser.add_argument("--denoiser-lr", type=float, default=None)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    started = time.perf_counter()
    config = pipeline_config(args.scale)
    plan = EnergyViewSettings.for_scale(args.scale).plan
    if args.kl is not None:
        config = replace(config, vae_training=replace(config.vae_training, kl_weight=args.kl))
    if args.vae_lr_schedule is not None:
        config = replace(config, vae_training=replace(config.vae_training,
                                                      lr_schedule=args.vae_lr_schedule))
    if args.denoiser_width is not None:
        config = replace(config, denoiser_width=args.denoiser_width)
    if args.denoiser_lr is not None:
        config = replace(config, denoiser_training=replace(config.denoiser_training,
                                                           lr=args.denoiser_lr))
    if args.denoiser_steps is not None:
        config = config.with_steps(denoiser=args.denoiser_steps)
        plan = replace(plan, denoiser_step_cap=args.denoiser_steps)
    pipe = SeedPipelines(load_pipeline(config, "cpu", plan=plan))(args.seed)
    trained_s = time.perf_counter() - started
    test = load_or_build_text_to_motion_test(
        config, LatentCountSettings.for_scale(args.scale).test_clips, data=pipe.data)
    vae, denoiser = model_gates.pipeline_records(pipe, test)
    row = {"label": args.label, "scale": args.scale, "seed": args.seed,
           "vae": {"architecture": config.vae_architecture,
                   "kl_weight": config.vae_training.kl_weight,
                   "lr_schedule": config.vae_training.lr_schedule,
                   "foot_velocity_weight": config.vae_training.foot_velocity_weight},
           "denoiser": {"width": config.denoiser_width, "layers": config.denoiser_layers,
                        "steps": plan.denoiser_step_cap,
                        "lr": config.denoiser_training.lr},
           "train_and_load_s": round(trained_s, 1), "test_clips": len(test),
           "gates": {record["family"]: {metric: {k: gate[k] for k in ("value", "data",
                                                                     "passed")}
                                        for metric, gate in record["gate"].items()}
                     for record in (vae, denoiser)}}
    with args.out.open("a") as handle:
        handle.write(json.dumps(row) + "\n")
    for family, gates in row["gates"].items():
        for metric, gate in gates.items():
            ratio = (gate["value"] / gate["data"] if gate["data"] and gate["value"] is not None
                     else None)
            print(f"{family:16s} {metric:22s} value {gate['value']} data {gate['data']} "
                  f"ratio {ratio} passed {gate['passed']}")


if __name__ == "__main__":
    main()
