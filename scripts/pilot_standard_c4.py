"""Pilot after the first standard run (docs/COMPUTE.md §8): GMD-C4's standard motion models
(notebook 03, ``emphasis_study.Settings.for_scale("standard")``: loss scaling k = 10 and the
Gaussian Emphasis projection c = 10, text-conditioned absolute-root x0 UNet 64 × (1, 1) with
the input skip, T = 100, b32, lr 1e-3, fp32) and their ``x0_error_vs_gaussian`` gate (gates
version 3, ≤ 0.9) at several step counts of one training run.

The spec is ``Variant(method, 10).spec(settings.base_spec(), seed)`` with a fixed number of
steps (the largest of ``--checks``); an Emphasis model trains on ``project_windows`` of the
training windows with the seed's matrix, as ``emphasis_study.load_or_train_variant`` does, and
is measured in its projected space (``ProjectedFeatureSpace``), as ``model_gates.
emphasis_study_records`` does: ``model_gates.denoising_gate_values`` on the test windows
against the training windows, the seed's noise. Nothing in training depends on the step count
(no learning-rate schedule), so a check's EMA weights are those of a run of that many steps.
One JSON line per check, appended to ``--out``::

    PYTHONPATH=src python scripts/pilot_standard_c4.py --method emphasis --seed 0 \
        --checks 900 1200 1500 1800 2400 --out docs/pilot_standard_c4.jsonl
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import time
from pathlib import Path

import torch

from repro.gmd import emphasis_study as study
from repro.gmd import model_gates
from repro.gmd.models import TrainedGMD, load_or_train_gmd
from repro.gmd.windows import load_windows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--method", choices=study.METHODS, required=True)
    parser.add_argument("--value", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--checks", type=int, nargs="+", default=[900, 1200, 1500, 1800, 2400])
    parser.add_argument("--frames", type=int, default=None,
                        help="window length (default: the standard's 48; stride = frames / 2)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    checks = sorted(args.checks)
    every = math.gcd(*checks)

    settings = study.Settings.for_scale("standard")
    base = settings.base_spec()
    if args.frames is not None:
        base = base.replace(data=dataclasses.replace(base.data, frames=args.frames,
                                                     stride=args.frames // 2))
    value = int(args.value) if float(args.value).is_integer() else args.value
    variant = study.Variant(args.method, value)
    spec = variant.spec(base, args.seed).replace(train_steps=checks[-1], validate_every=every,
                                                 patience=10**6)
    train = load_windows(base.data)
    test = load_windows(base.data, "test", statistics=(train.mean, train.std))
    projection = variant.projection(args.seed, train.x.shape[1])
    data = train if projection is None else study.project_windows(train, projection)
    space = train.space("motion")
    if projection is not None:
        space = study.ProjectedFeatureSpace(space.task, space.representation, space.mean,
                                            space.std, projection)
    diffusion = spec.diffusion()
    spent = {"checks": 0.0}
    cpu0, wall0 = time.process_time(), time.perf_counter()

    def check(step: int, loss: float, ema: torch.nn.Module) -> None:
        if step not in checks:
            return
        c0 = time.process_time()
        train_cpu = c0 - cpu0 - spent["checks"]
        trained = TrainedGMD(copy.deepcopy(ema).eval(), diffusion, space, spec,
                             vocabulary=data.vocabulary)
        row = {"family": "gmd_motion", "design": (f"{spec.base_channels} x "
                                                  f"{tuple(spec.channel_mults)} + input skip"),
               "arm": variant.label, "method": args.method, "value": args.value,
               "seed": args.seed, "frames": spec.data.frames, "step": step,
               "T": spec.diffusion_steps,
               "batch": spec.batch_size, "lr": spec.lr,
               "parameters": sum(p.numel() for p in ema.parameters()), "held_out_loss": loss,
               **model_gates.denoising_gate_values(trained, test, train, seed=args.seed)}
        row["gate_passed"] = bool(row["x0_error_vs_gaussian"] <= 0.9)
        spent["checks"] += time.process_time() - c0
        row.update({"train_cpu_seconds": round(train_cpu, 1),
                    "ms_per_step": round(1000 * train_cpu / step, 1),
                    "check_cpu_seconds": round(spent["checks"], 1),
                    "wall_seconds": round(time.perf_counter() - wall0, 1)})
        with args.out.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(row) + "\n")
        print(row, flush=True)

    load_or_train_gmd(spec, data, on_validation=check, retrain=True)


if __name__ == "__main__":
    main()
