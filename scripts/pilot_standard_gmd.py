"""Pilot for the standard scale (issue #32, docs/COMPUTE.md §4): does a tiny GMD UNet pass its
fitness gate (gates version 3: held-out x̂0 error ≤ 0.9× the Gaussian denoiser's) within the
standard scale's per-model share, and what does a step cost here?

Notebook 01's full-mode windows (48 frames): ``--task motion`` GMD-A4's motion model on the
relative-root windows; ``--task trajectory`` the guidance experiments' trajectory model
(absolute root, T = 1000 cosine: GMD-A3, B2, F1; the path-length gate needs samples and is
not measured here). One torch thread, fp32, no plateau stop: the EMA weights' x̂0 gate value
is measured at every held-out evaluation (``validate_every``) on the way to ``--steps``. One
JSON line per check goes to ``--out`` (appended, so a stopped run keeps its rows)::

    PYTHONPATH=src python scripts/pilot_standard_gmd.py --task motion --width 64 --mults 1 1 \
        --input-skip --prediction x0 --steps 1500 --every 300 \
        --out docs/pilot_standard_motion.jsonl
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import torch

from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.models import TrainedGMD, load_or_train_gmd
from repro.gmd.windows import load_windows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", choices=("motion", "trajectory"), default="motion")
    parser.add_argument("--representation", choices=("relative", "absolute"), default=None,
                        help="the motion windows' root (default: A4's relative)")
    parser.add_argument("--text", action="store_true",
                        help="text-conditioned motion model (GMD-B3, C4, F1's second stage)")
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--mults", type=float, nargs="+", default=[1.0, 1.0])
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--steps", type=int, default=1200)
    parser.add_argument("--every", type=int, default=300)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--input-skip", action="store_true",
                        help="UNet1D(input_skip=True): a full-rank input-to-output path")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)

    settings = x0eps.Settings.for_scale("paper")
    if args.task == "motion":
        data = settings.data(representation=args.representation
                             or settings.motion_representation)
        spec = settings.spec("motion", args.prediction, data, seed=args.seed).replace(
            text_conditioned=args.text)
    else:
        data = settings.data()
        spec = settings.guidance_trajectory_spec(args.prediction, data, seed=args.seed)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    spec = spec.replace(
        base_channels=args.width, channel_mults=tuple(args.mults), train_steps=args.steps,
        batch_size=args.batch, lr=args.lr, validate_every=args.every, patience=10**6,
        autocast=None, input_skip=args.input_skip)
    started = time.perf_counter()
    diffusion = spec.diffusion()

    def check(step: int, loss: float, ema: torch.nn.Module) -> None:
        trained = TrainedGMD(copy.deepcopy(ema).eval(), diffusion, train.space(args.task), spec)
        gate = model_gates.denoising_gate_values(trained, test, train, seed=args.seed)
        row = {"task": args.task, "width": args.width, "mults": args.mults,
               "prediction": args.prediction, "T": spec.diffusion_steps,
               "representation": data.representation, "text": spec.text_conditioned,
               "input_skip": args.input_skip,
               "batch": args.batch, "lr": args.lr, "seed": args.seed, "step": step,
               "held_out_loss": loss, "parameters": sum(p.numel() for p in ema.parameters()),
               "cpu_seconds": round(time.process_time(), 1),
               "wall_seconds": round(time.perf_counter() - started, 1), **gate}
        with args.out.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(row) + "\n")
        print(row, flush=True)

    load_or_train_gmd(spec, train, on_validation=check, retrain=True)


if __name__ == "__main__":
    main()
