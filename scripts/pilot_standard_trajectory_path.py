"""Pilot after the first standard run (docs/COMPUTE.md §8): the standard GMD trajectory models'
``path_length`` gate (gates version 3: unguided samples' mean horizontal root path length
within ½–2× the test windows'), measured both ways notebook 01 measures it, at several step
counts of one training run, with the x̂0 gate beside it.

The model is notebook 01's standard trajectory model (``x0_vs_eps.Settings.for_scale(
"standard").guidance_trajectory_spec``, the same cache key as ``spec("trajectory", …)``:
absolute root, T = 100 cosine, b32, lr 1e-3, fp32) with ``--width``/``--mults`` and a fixed
number of steps (the largest of ``--checks``); nothing in training depends on the step count
(no learning-rate schedule, the EMA warm-up counts updates), so the EMA weights at a check are
those of a run of that many steps. At each check, 32 unguided samples with the seed:

* ``a3_*``: as GMD-A3 records it (``goal_reaching_study``'s unguided samples: ``sample(…,
  clip_x0="gmd")``, an ε model's x̂0 clamped to GMD's ±6, an x0 model's not);
* ``a4_*``: as GMD-A4 records it (``guidance.sample(model, 32, seed=s)``: ``clip_x0="auto"``,
  an ε model's x̂0 clamped to ± the largest |value| of its training windows);

and for each: ``path_length`` (the gate's value, ``model_gates.path_length`` mean), its
median over samples and the share of samples above 2× the test windows', the path length of
the root smoothed by a 5-frame moving average (``smooth_path``) and of the root every 6th
frame (``coarse_path``; both drop high-frequency jitter, keep speed), the start-to-end
displacement (``displacement``) and the root jerk (m/s³). The test windows' same numbers go
in every row (``reference_*``). ``x0_error_vs_gaussian`` is ``model_gates.
denoising_gate_values``. CPU seconds of training (``train_cpu_seconds``, checks excluded) and
of the checks are kept apart. One JSON line per check, appended to ``--out``::

    PYTHONPATH=src python scripts/pilot_standard_trajectory_path.py --prediction x0 --seed 0 \
        --width 16 --mults 1 2 --checks 1000 2000 3000 \
        --out docs/pilot_standard_trajectory_path.jsonl
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import time
from pathlib import Path

import numpy as np
import torch

from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import resolve_clamp, sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import TrainedGMD, load_or_train_gmd
from repro.gmd.windows import load_windows

SAMPLES = 32  # settings.goals at the standard scale: A3's unguided batch and A4's record


def path_summary(root: np.ndarray) -> dict[str, float]:
    """Path statistics of root paths (B, T, 3) = (x, y, z), metres."""
    xz = np.asarray(root, dtype=np.float64)[..., [0, 2]]
    raw = np.linalg.norm(np.diff(xz, axis=1), axis=-1).sum(axis=1)
    kernel = np.ones(5) / 5
    smooth = np.stack([np.stack([np.convolve(p[:, k], kernel, mode="valid") for k in (0, 1)],
                                axis=-1) for p in xz])
    smooth_path = np.linalg.norm(np.diff(smooth, axis=1), axis=-1).sum(axis=1)
    coarse = xz[:, ::6]
    coarse_path = np.linalg.norm(np.diff(coarse, axis=1), axis=-1).sum(axis=1)
    displacement = np.linalg.norm(xz[:, -1] - xz[:, 0], axis=-1)
    return {"path_length": float(raw.mean()), "path_median": float(np.median(raw)),
            "smooth_path": float(smooth_path.mean()), "coarse_path": float(coarse_path.mean()),
            "displacement": float(displacement.mean()), "per_sample": raw}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--prediction", choices=("x0", "epsilon"), required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=16)
    parser.add_argument("--mults", type=float, nargs="+", default=[1.0, 2.0])
    parser.add_argument("--checks", type=int, nargs="+", default=[1000, 2000, 3000])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    checks = sorted(args.checks)
    every = math.gcd(*checks)

    settings = x0eps.Settings.for_scale("standard")
    data = settings.data()
    spec = settings.guidance_trajectory_spec(args.prediction, data, seed=args.seed)
    if spec != settings.spec("trajectory", args.prediction, data, seed=args.seed):
        raise RuntimeError("at the standard scale A3's and A4's trajectory specs should agree")
    design = f"{args.width} x {tuple(args.mults)}"
    mults = tuple(int(m) if float(m).is_integer() else m for m in args.mults)
    spec = spec.replace(base_channels=args.width, channel_mults=mults,
                        train_steps=checks[-1], validate_every=every, patience=10**6)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    space = train.space("trajectory")
    bound = float(train.channels("trajectory").abs().max())
    with torch.no_grad():
        reference = path_summary(space.root_positions(test.trajectory()).cpu().numpy())
    reference_jerk = float(jitter_of(test.space("trajectory"), test.trajectory()).jerk)
    diffusion = spec.diffusion()
    spent = {"checks": 0.0}
    cpu0, wall0 = time.process_time(), time.perf_counter()

    def check(step: int, loss: float, ema: torch.nn.Module) -> None:
        if step not in checks:
            return
        c0 = time.process_time()
        train_cpu = c0 - cpu0 - spent["checks"]
        trained = TrainedGMD(copy.deepcopy(ema).eval(), diffusion, space, spec, x0_bound=bound)
        row = {"family": "gmd_trajectory", "design": design, "width": args.width,
               "mults": list(mults), "prediction": args.prediction, "seed": args.seed,
               "step": step, "T": spec.diffusion_steps, "batch": spec.batch_size,
               "lr": spec.lr, "parameters": sum(p.numel() for p in ema.parameters()),
               "held_out_loss": loss,
               **model_gates.denoising_gate_values(trained, test, train, seed=args.seed)}
        for tag, clamp in (("a3", "gmd"), ("a4", "auto")):
            x = sample(trained, SAMPLES, seed=args.seed, clip_x0=clamp)
            with torch.no_grad():
                summary = path_summary(space.root_positions(x).cpu().numpy())
            per_sample = summary.pop("per_sample")
            row[f"{tag}_clamp"] = resolve_clamp(trained, clamp)
            row.update({f"{tag}_{k}": v for k, v in summary.items()})
            row[f"{tag}_share_above_2x"] = float(np.mean(per_sample >
                                                         2 * reference["path_length"]))
            row[f"{tag}_root_jerk"] = float(jitter_of(trained, x).jerk)
            row[f"{tag}_gate_passed"] = bool(0.5 * reference["path_length"] <=
                                             summary["path_length"] <=
                                             2 * reference["path_length"])
        row.update({f"reference_{k}": v for k, v in reference.items() if k != "per_sample"})
        row["reference_root_jerk"] = reference_jerk
        row["x0_gate_passed"] = bool(row["x0_error_vs_gaussian"] <= 0.9)
        spent["checks"] += time.process_time() - c0
        row.update({"train_cpu_seconds": round(train_cpu, 1),
                    "ms_per_step": round(1000 * train_cpu / step, 1),
                    "check_cpu_seconds": round(spent["checks"], 1),
                    "wall_seconds": round(time.perf_counter() - wall0, 1)})
        with args.out.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(row) + "\n")
        print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()},
              flush=True)

    load_or_train_gmd(spec, train, on_validation=check, retrain=True)


if __name__ == "__main__":
    main()
