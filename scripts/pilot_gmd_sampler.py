"""Sampler and denoiser pilot of the GMD motion model (issue #14): where do the samples'
foot skating and joint jerk come from?

On notebook 01's full-mode windows (absolute root, 48 frames), with
``repro.gmd.denoiser_diagnostics``:

* ``--noise-floor``: the gate's skating and jerk of 256 test windows with white noise of σ
  (model units) added to every channel, to the root channels 0:4 only, or to the joint
  positions (ric) only: the per-frame precision a sample needs.
* otherwise a model (default: the design pilot's config C, 288 × (1, 0.5, 0.25), batch 32,
  lr 1e-3, x0, T = ``--diffusion-steps``) trained with the held-out validation of
  ``gmd.models.validation_split`` (patience never fires; ``--steps`` is the length), checked
  every ``--check-every`` steps: the gate's skating and jerk of 64 unguided samples (seed 0);
  the EMA weights' x̂0 error per feature block on 128 held-out windows at several t, beside
  the noise √(1 − ᾱ_t) that x_t holds; the skating and jerk of their x̂0 at t = 0 (the best
  the sampler's last step can return); the high-frequency share of samples, of x̂0 at t = 0
  and of the data. Arms: ``--prediction epsilon``, ``--root-weight k²`` (loss weight on the
  root channels 0:4, GMD's loss scaling), ``--upsampling nearest`` (nearest ×2 + conv in place
  of the transposed convolutions), ``--diffusion-steps 1000`` (GMD's T).

One torch thread. Prints one JSON line per check and writes them to ``--out``.

    PYTHONPATH=src python scripts/pilot_gmd_sampler.py --noise-floor --out docs/x.jsonl
    PYTHONPATH=src python scripts/pilot_gmd_sampler.py --diffusion-steps 1000 --steps 2400 \
        --out build/pilot/T1000.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import torch

from repro.core.training import ValidationSet, train_diffusion
from repro.gmd import x0_vs_eps as x0eps
from repro.gmd.denoiser_diagnostics import (
    high_frequency_share,
    noise_floor,
    reconstruction,
    x0_error_by_block,
)
from repro.gmd.guidance import sample
from repro.gmd.model_gates import motion_gate_values
from repro.gmd.models import GMDModelSpec, TrainedGMD, validation_split
from repro.gmd.windows import load_windows

#: white-noise levels (model units) of ``--noise-floor``
NOISE_SIGMAS = (0.0, 0.0015, 0.003, 0.0065, 0.0125, 0.025, 0.05)

def measure(joints: torch.Tensor) -> dict[str, float]:
    return motion_gate_values(joints, fid=None)


def nearest_upsampling(model: torch.nn.Module) -> torch.nn.Module:
    """Replace the UNet's transposed-convolution upsamplers (k = 4, stride 2) by nearest-
    neighbour ×2 followed by a k = 3 convolution (Odena et al. 2016's fix for checkerboard
    artifacts); the pilot's ``--upsampling nearest`` arm."""
    for k, up in enumerate(model.upsamplers):
        width = up.in_channels
        model.upsamplers[k] = torch.nn.Sequential(torch.nn.Upsample(scale_factor=2),
                                                  torch.nn.Conv1d(width, width, 3, padding=1))
    return model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noise-floor", action="store_true")
    parser.add_argument("--diffusion-steps", type=int, default=100)
    parser.add_argument("--steps", type=int, default=1200)
    parser.add_argument("--check-every", type=int, default=600)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--base", type=int, default=288)
    parser.add_argument("--mults", type=float, nargs="+", default=[1, 0.5, 0.25])
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--lr", type=float, default=1e-3)
    parser.add_argument("--upsampling", choices=("transposed", "nearest"),
                        default="transposed")
    parser.add_argument("--prediction", choices=("x0", "epsilon"), default="x0")
    parser.add_argument("--root-weight", type=float, default=1.0,
                        help="loss weight on the root channels 0:4 (GMD's loss scaling k²)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)
    settings = x0eps.Settings.for_mode(False)
    train = load_windows(settings.data())
    test = load_windows(train.config, "test", statistics=(train.mean, train.std))
    lines: list[dict[str, Any]] = []
    if args.noise_floor:
        lines = [{"kind": "noise_floor", **row} for row in noise_floor(
            test.space("motion"), test.x[:256], NOISE_SIGMAS,
            {"all": slice(0, 263), "root": slice(0, 4), "ric": slice(4, 67)}, measure)]
        print("".join(json.dumps(r) + "\n" for r in lines), end="")
        Path(args.out).write_text("".join(json.dumps(r) + "\n" for r in lines), "utf-8")
        return
    spec = GMDModelSpec(task="motion", prediction=args.prediction, data=train.config,
                        base_channels=args.base, channel_mults=tuple(args.mults),
                        diffusion_steps=args.diffusion_steps, train_steps=args.steps,
                        batch_size=args.batch, lr=args.lr, validate_every=args.check_every,
                        patience=1000,
                        feature_weights=None if args.root_weight == 1.0
                        else (args.root_weight,) * 4 + (1.0,) * 259)
    fit, held = validation_split(train, spec.validation_fraction)
    validation = ValidationSet(train.x[held])
    diffusion = spec.diffusion()
    T = args.diffusion_steps
    timesteps = sorted({0, 1, 2, 5, T // 50, T // 10, T // 2, T - 1})
    started = time.process_time()
    measuring = [0.0]

    def on_validation(step: int, loss: float, ema_model: torch.nn.Module) -> None:
        if step == 0:
            return
        t0 = time.process_time()
        trained = TrainedGMD(ema_model, diffusion, train.space("motion"), spec, None,
                             x0_bound=float(train.x.abs().max()))
        held_x = train.x[held][:128]
        errors = x0_error_by_block(ema_model, diffusion, held_x, timesteps)
        with torch.no_grad():
            drawn = sample(trained, args.samples, seed=0)
        values = measure(trained.space.joints(drawn))
        rebuilt = reconstruction(ema_model, diffusion, held_x, 0)
        rebuilt_values = measure(trained.space.joints(rebuilt))
        measuring[0] += time.process_time() - t0
        lines.append({"kind": "model", "diffusion_steps": T, "base": args.base,
                      "mults": args.mults, "batch": args.batch, "lr": args.lr, "step": step,
                      "prediction": args.prediction, "upsampling": args.upsampling,
                      "root_weight": args.root_weight, "val_loss": loss, **values,
                      "x0_rms_error": errors,
                      "x0_at_t0": rebuilt_values,
                      "high_frequency_share": high_frequency_share(drawn),
                      "high_frequency_share_data": high_frequency_share(held_x),
                      "high_frequency_share_x0_at_t0": high_frequency_share(rebuilt),
                      "train_cpu_s": time.process_time() - started - measuring[0],
                      "measure_cpu_s": measuring[0]})
        print(json.dumps(lines[-1]), flush=True)
        Path(args.out).write_text("".join(json.dumps(r) + "\n" for r in lines), "utf-8")

    model = spec.build_model()
    if args.upsampling == "nearest":
        nearest_upsampling(model)
    train_diffusion(model, diffusion, train.x[fit].contiguous(),
                    spec.train_config(), validation=validation, on_validation=on_validation,
                    progress=False)


if __name__ == "__main__":
    main()
