"""Pilot: where the root jerk of GMD's absolute-root trajectory models comes from.

For notebook 01's standard trajectory models (x0 and ε, one seed), the root jerk of x̂0 at
recorded steps of unguided sampling, and of the one-step x̂0 from test windows noised to a
small t — the network's denoising alone, without sampling's drift — with its error in
millimetres (rms, and rms of the third difference that jerk reads: jerk = third difference
× fps³). One thread; reads the models from the cache (trains them if missing).

    PYTHONPATH=src python scripts/pilot_trajectory_jerk.py --seed 0 \
        --out pilots/gmd_trajectory_samples.jsonl
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.guidance import sample
from repro.gmd.measurements import jitter_of
from repro.gmd.models import load_or_train_gmd
from repro.gmd.windows import load_windows

STEPS = (0, 1, 2, 5, 10, 20)


def _millimetres(values: torch.Tensor) -> float:
    return round(1000 * float(values.pow(2).mean().sqrt()), 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_scale("standard")
    data = settings.data(None)
    train = load_windows(data)
    test = load_windows(data, "test", statistics=(train.mean, train.std))
    space = test.space("trajectory")
    clean = test.trajectory()[:args.n]
    path = space.root_positions(clean)[..., [0, 2]]
    rows = [{"label": "traj-jerk data", "root_jerk": float(jitter_of(space, clean).jerk),
             "third_difference_mm": _millimetres(torch.diff(path, n=3, dim=1))}]
    for prediction in ("epsilon", "x0"):
        model = load_or_train_gmd(settings.spec("trajectory", prediction, data, args.seed), train)
        alpha_bar = torch.as_tensor(model.diffusion.alphas_cumprod, dtype=torch.float32)
        x, trajectory = sample(model, args.n, seed=args.seed, return_trajectory=True,
                               trajectory_timesteps=list(STEPS))
        sampled = {t: float(jitter_of(model, trajectory.pred_x0[i]).jerk)
                   for i, t in enumerate(trajectory.timesteps)}
        one_step = {}
        generator = torch.Generator().manual_seed(args.seed)
        for t in STEPS:
            noise = torch.randn(clean.shape, generator=generator)
            x_t = alpha_bar[t].sqrt() * clean + (1 - alpha_bar[t]).sqrt() * noise
            with torch.no_grad():
                out = model.model(x_t, torch.full((args.n,), t, dtype=torch.long))
            x0_hat = (out if prediction == "x0"
                      else (x_t - (1 - alpha_bar[t]).sqrt() * out) / alpha_bar[t].sqrt())
            estimate = space.root_positions(x0_hat)[..., [0, 2]]
            one_step[t] = {"root_jerk": float(jitter_of(model, x0_hat).jerk),
                           "error_mm": _millimetres(estimate - path),
                           "third_difference_mm": _millimetres(torch.diff(estimate, n=3, dim=1)),
                           "noise_over_signal": float(((1 - alpha_bar[t]) / alpha_bar[t]).sqrt())}
        rows.append({"label": f"traj-jerk {prediction} seed {args.seed}",
                     "final_root_jerk": float(jitter_of(model, x).jerk),
                     "sampled_x0_root_jerk": sampled, "one_step": one_step})
    for row in rows:
        print(json.dumps(row))
    if args.out is not None:
        with args.out.open("a") as f:
            f.writelines(json.dumps(row) + "\n" for row in rows)


if __name__ == "__main__":
    main()
