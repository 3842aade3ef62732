"""Pilot: what the paper's AGD step sizes (EnergyMoGen Table 9) mean on the standard pipeline,
for a transfer of EMG-4's steps registered before a run.

On the standard pipeline of training seed 0 (``load_pipeline``, the cached models of a
standard run: point ``REPRO_CACHE_DIR`` at its cache), for Table 9's grid scaled by each
``--kappa``: the text embedding's relative change by the last block, ‖Δc‖/‖c‖ at t = 500
(``sef_ablation.emg4.agd_relative_change``, on notebook 05's items of seed 0), and R@3 of γ = 0, of
the scaled largest row and of the scaled smallest row, sampled as notebook 05 samples them
(``run_rows``) on ``--items-per-pair`` items per held-out pair, with the CPU seconds of each
row (one thread). One JSON line per κ goes to ``--out``::

    REPRO_CACHE_DIR=/path/to/standard/cache PYTHONPATH=src python \\
        scripts/pilot_emg4_transfer.py --kappa 1 3 10 30 --out pilots/emg4_transfer.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from repro.energymogen.data import energy_view_items
from repro.energymogen.pipeline import Sampler, load_pipeline
from repro.energymogen.sef_ablation import common, emg4
from repro.energymogen.sef_ablation.common import SEFAblationSettings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kappa", type=float, nargs="+", default=[1.0, 3.0, 10.0, 30.0])
    parser.add_argument("--items-per-pair", type=int, default=None,
                        help="items per held-out pair (the standard pipeline's by default)")
    parser.add_argument("--no-r3", action="store_true", help="the embedding change only")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = SEFAblationSettings.for_scale("standard")
    config = settings.pipeline
    if args.items_per_pair is not None:
        config = replace(config, items_per_pair=args.items_per_pair)
    pipe = load_pipeline(config, "cpu", plan=settings.plan)
    items = energy_view_items(pipe.data, 0, config.items_per_pair)
    texts = list(items.multi_texts)
    largest, smallest = common.TABLE9_GAMMAS[1], common.TABLE9_GAMMAS[-1]
    baseline = None
    with args.out.open("a") as out:
        for kappa in args.kappa:
            row: dict = {"kappa": kappa, "items": len(items.multi_texts),
                         "items_per_pair": config.items_per_pair}
            for name, gammas in (("largest", largest), ("smallest", smallest)):
                scaled = (kappa * gammas[0], kappa * gammas[1])
                row[f"gammas_{name}"] = scaled
                row[f"relative_change_{name}"] = emg4.agd_relative_change(pipe, texts, scaled)
            if not args.no_r3:
                rows = {"largest": Sampler("single", gammas=row["gammas_largest"]),
                        "smallest": Sampler("single", gammas=row["gammas_smallest"])}
                if baseline is None:
                    rows["zero"] = Sampler("single", gammas=(0.0, 0.0))
                for name, sampler in rows.items():
                    start = time.process_time()
                    measured = common.run_rows(pipe, {name: sampler}, [0])
                    row[f"r3_{name}"] = float(np.mean(measured[name]["r_precision_top3"]))
                    row[f"cpu_s_{name}"] = round(time.process_time() - start, 1)
                    if name == "zero":
                        baseline = row["r3_zero"]
                row["r3_zero"] = baseline
            print(json.dumps(row))
            out.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
