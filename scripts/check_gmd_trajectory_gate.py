"""Does notebook 01's trajectory model pass its ``gmd_trajectory`` gate? (issue #14)

Trains (or loads from the cache) notebook 01's full-mode trajectory x0 and ε models as the
notebook's spec defines them (``x0_vs_eps.Settings.spec``: trained to convergence), draws 256
unguided samples of each (seed 0) and measures root jerk and path length against the test
windows' own (``gmd.model_gates.trajectory_gate_values``). One torch thread; prints JSON.

    PYTHONPATH=src python scripts/check_gmd_trajectory_gate.py
"""

from __future__ import annotations

import json
import time

import torch

from repro.core.gates import gate_results
from repro.gmd import model_gates
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import sample
from repro.gmd.models import load_or_train_gmd
from repro.gmd.windows import load_windows


def main() -> None:
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("paper")
    train = load_windows(settings.data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    reference = model_gates.trajectory_gate_values(test.space("trajectory"), test.trajectory())
    print("reference", json.dumps(reference), flush=True)
    for prediction in ("epsilon", "x0"):
        started = time.process_time()
        trained = load_or_train_gmd(settings.spec("trajectory", prediction, train.config), train)
        values = model_gates.trajectory_gate_values(trained, sample(trained, 256, seed=0))
        gates = gate_results("gmd_trajectory", values, reference)
        print(prediction, json.dumps({**model_gates.training_summary(trained),
                                      "cpu_seconds": time.process_time() - started,
                                      "values": values,
                                      "passed": all(g["passed"] for g in gates.values())}),
              flush=True)


if __name__ == "__main__":
    main()
