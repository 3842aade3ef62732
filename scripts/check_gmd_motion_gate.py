"""Does notebook 01's motion x0 model pass its ``gmd_motion`` gate? (issue #14)

Trains (or loads from the cache) notebook 01's full-mode GMD-A4 motion model as the notebook's
spec defines it (``x0_vs_eps.Settings.spec`` on ``motion_data()``: relative-root windows,
trained to convergence up to ``MOTION_TRAINING``'s cap), and measures the gate the way the
notebook does: ``settings.generated`` unguided samples (seed = the model's seed), their foot
skating, joint jerk and FID with notebook 01's evaluator against the test windows' own values
(the training windows' FID for the reference). One torch thread; prints JSON and appends it
to ``--out``. The model lands in the cache under the notebook's key, so a later full run loads
it.

    PYTHONPATH=src python scripts/check_gmd_motion_gate.py --seed 1 --out build/motion_gate.jsonl
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
from repro.gmd.models import load_or_train_gmd
from repro.gmd.windows import load_windows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="training and sampling seed")
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--out", required=True, help="JSON lines, appended")
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_mode(False)
    train = load_windows(settings.motion_data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    # notebook 01's evaluator and reference, as its GMD-A4 cells build them (base seed 0)
    evaluation = model_gates.motion_evaluation(
        train, test, settings.evaluator_config(train.fingerprint),
        reference_samples=settings.generated, seed=0)
    reference = model_gates.motion_gate_values(test.space("motion").joints(test.x),
                                               fid=evaluation.real_fid)
    started = time.process_time()
    spec = settings.spec("motion", args.prediction, train.config, seed=args.seed)
    trained = load_or_train_gmd(spec, train)
    values = model_gates.unguided_motion_gate_values(
        trained, settings.generated, seed=args.seed, evaluator=evaluation.evaluator,
        test_embeddings=evaluation.test_embeddings)
    gates = gate_results("gmd_motion", values, reference)
    row = {"prediction": args.prediction, "seed": args.seed,
           "representation": train.config.representation, "cache_key": trained.cache_key,
           **model_gates.training_summary(trained),
           "train_seconds": trained.metrics.get("seconds"),
           "cpu_seconds": time.process_time() - started, "values": values,
           "reference": reference,
           "bounds": {m: {k: v for k, v in g.items() if k in ("at_most", "at_least")}
                      for m, g in gates.items()},
           "passed": all(g["passed"] for g in gates.values())}
    line = json.dumps(row)
    print(line, flush=True)
    with Path(args.out).open("a", encoding="utf-8") as out:
        out.write(line + "\n")


if __name__ == "__main__":
    main()
