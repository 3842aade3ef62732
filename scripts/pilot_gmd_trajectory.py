"""Pilot: does notebook 01's trajectory model pass its ``gmd_trajectory`` gate at another width?
(issue #14)

As ``check_gmd_trajectory_gate.py`` (notebook 01's full-mode trajectory specs, trained to
convergence, 256 unguided samples of seed 0, root jerk and path length against the test
windows' own), with ``base_channels`` and ``channel_mults`` replaced. One torch thread; each
result is appended as one JSON line to ``--out`` as soon as it is measured, so a stopped pilot
keeps what it finished.

    PYTHONPATH=src python scripts/pilot_gmd_trajectory.py --base 64 --mults 1 2 4 \\
        --out docs/pilot_gmd_trajectory.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import torch

from repro.core.gates import gate_results
from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import sample
from repro.gmd.models import load_or_train_gmd, parameter_count
from repro.gmd.windows import load_windows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=int, required=True)
    parser.add_argument("--mults", type=float, nargs="+", required=True)
    parser.add_argument("--predictions", nargs="+", default=["epsilon", "x0"],
                        choices=["epsilon", "x0"])
    parser.add_argument("--steps", type=int, default=None,
                        help="step cap (default: notebook 01's full-mode cap)")
    parser.add_argument("--lr", type=float, default=None,
                        help="learning rate (default: notebook 01's)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("paper")
    train = load_windows(settings.data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    reference = model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    for prediction in args.predictions:
        spec = settings.spec("trajectory", prediction, train.config).replace(
            base_channels=args.base, channel_mults=tuple(args.mults))
        if args.steps is not None:
            spec = spec.replace(train_steps=args.steps)
        if args.lr is not None:
            spec = spec.replace(lr=args.lr)
        started = time.process_time()
        trained = load_or_train_gmd(spec, train)
        values = model_gates.trajectory_gate_values(trained, sample(trained, 256, seed=0))
        gates = gate_results("gmd_trajectory", values, reference)
        row = {"prediction": prediction, "base_channels": args.base,
               "channel_mults": list(args.mults), "lr": spec.lr,
               "parameters": parameter_count(trained),
               **model_gates.training_summary(trained),
               "cpu_seconds": time.process_time() - started, "reference": reference,
               "values": values, "passed": all(g["passed"] for g in gates.values())}
        with args.out.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
