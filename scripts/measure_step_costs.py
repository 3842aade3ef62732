"""Measure the CPU cost per training step and per sampling step of the package's model
families, today's sizes and tiny candidates: the tables of docs/COMPUTE.md.

One process, one torch thread (``torch.set_num_threads(1)``), synthetic data (the speed does
not depend on the values). A training step is the package's own loop (``core.training.
train_diffusion``, ``models.vae.train_vae``, ``models.latent_denoiser.train_latent_denoiser``,
``models.evaluator.train_evaluator``): a short warm-up run, then a timed run of as many steps
as fill about ``--seconds`` seconds; ms/step = its seconds / its steps. A sampling step is
one forward pass without gradients (DDPM/DDIM step), or forward + backward to the input (a
guided step), of a batch. Every row is printed as one JSON line (``--out`` also writes them).

    PYTHONPATH=src python scripts/measure_step_costs.py --out docs/step_costs.jsonl
    PYTHONPATH=src python scripts/measure_step_costs.py --quick   # seconds: a test of the script
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import TrainConfig, autocast_context, train_diffusion
from repro.energymogen.config import PipelineConfig
from repro.energymogen.pipeline import denoiser_kwargs, scaled_linear_betas, vae_kwargs
from repro.gmd.coefficients import schedule_diffusion
from repro.models.evaluator import EvaluatorConfig, train_evaluator
from repro.models.latent_denoiser import LatentDenoiser, train_latent_denoiser
from repro.models.unet import UNet1D
from repro.models.vae import MotionVAE, VAETrainConfig, train_vae
from repro.run.bench_families import smooth_signals

Row = dict[str, Any]
PRECISIONS: dict[str, str | None] = {"fp32": None, "bf16": "bfloat16"}
#: bag-of-words width of a text-conditioned GMD motion model (about the stand-in vocabulary)
COND_DIM = 128


def _per_step(run: Callable[[int], float], target: float, quick: bool,
              setup_included: bool = False) -> tuple[float, int]:
    """(seconds per step, steps timed): a 2-step warm-up sizes a run of ~``target`` s. With
    ``setup_included`` (a loop whose seconds include its set-up) the 2-step run's seconds are
    subtracted: (t(n) − t(2)) / (n − 2)."""
    warm_seconds = run(2)
    steps = 3 if quick else int(min(60, max(3, round(target / max(warm_seconds / 2, 1e-4)))))
    if setup_included:
        steps += 2
        return (run(steps) - warm_seconds) / (steps - 2), steps
    return run(steps) / steps, steps


def unet_training(channels: int, base: int, mults: tuple[float, ...], frames: int, batch: int,
                  autocast: str | None, cond_dim: int | None = None) -> Callable[[int], float]:
    """Seconds of n ``train_diffusion`` steps of a UNet1D (T = 100 cosine, x0 target)."""
    data = smooth_signals(256, channels, frames, seed=1)
    cond = None if cond_dim is None else torch.rand(256, cond_dim)
    diffusion = schedule_diffusion("cosine", 100, "x0")

    def run(steps: int) -> float:
        torch.manual_seed(0)
        model = UNet1D(channels, base, mults, cond_dim=cond_dim)
        config = TrainConfig(steps=steps, batch_size=batch, lr=3e-4, seed=0, autocast=autocast,
                             cond_dropout=0.1 if cond is not None else 0.0)
        return train_diffusion(model, diffusion, data, config, cond=cond,
                               progress=False).seconds
    return run


def unet_sampling(channels: int, base: int, mults: tuple[float, ...], frames: int, batch: int,
                  autocast: str | None, guided: bool) -> Callable[[int], float]:
    """Seconds of n reverse-step model calls: forward (no grad), or forward + ∂/∂x (guided)."""
    torch.manual_seed(0)
    model = UNet1D(channels, base, mults).eval()
    x = torch.randn(batch, channels, frames)
    t = torch.full((batch,), 50)

    def run(steps: int) -> float:
        start = time.perf_counter()
        for _ in range(steps):
            with autocast_context(torch.device("cpu"), None if autocast is None
                                  else torch.bfloat16):
                if guided:
                    xg = x.clone().requires_grad_(True)
                    torch.autograd.grad(model(xg, t).float().square().sum(), xg)
                else:
                    with torch.no_grad():
                        model(x, t)
        return time.perf_counter() - start
    return run


def vae_training(width: int, batch: int, frames: int = 64) -> Callable[[int], float]:
    kwargs = {**vae_kwargs(PipelineConfig()), "width": width}
    motions = smooth_signals(256, 263, frames, seed=3).transpose(1, 2).contiguous()
    lengths = torch.full((256,), frames)

    def run(steps: int) -> float:
        torch.manual_seed(0)
        config = VAETrainConfig(steps=steps, batch_size=batch, lr=1e-3, seed=0)
        return train_vae(MotionVAE(**kwargs), motions, lengths, config).seconds
    return run


def _latent_inputs(tokens: int = 12) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    config = PipelineConfig()
    g = torch.Generator().manual_seed(2)
    latents = torch.randn(512, config.latent_count, config.latent_dim, generator=g)
    text = torch.randn(512, tokens, config.text_dim, generator=g)
    mask = torch.arange(tokens)[None] < torch.randint(4, tokens + 1, (512,), generator=g)[:, None]
    return latents, text, mask


def denoiser_training(width: int, layers: int, batch: int,
                      autocast: str | None) -> Callable[[int], float]:
    kwargs = {**denoiser_kwargs(PipelineConfig()), "width": width, "layers": layers}
    latents, text, mask = _latent_inputs()
    diffusion = GaussianDiffusion(scaled_linear_betas(1000), prediction="epsilon")

    def run(steps: int) -> float:
        torch.manual_seed(0)
        config = TrainConfig(steps=steps, batch_size=batch, lr=5e-4, ema_decay=0.999,
                             cond_dropout=0.1, seed=0, autocast=autocast)
        return train_latent_denoiser(LatentDenoiser(**kwargs), diffusion, latents, text, mask,
                                     config).seconds
    return run


def denoiser_sampling(width: int, layers: int, batch: int) -> Callable[[int], float]:
    """One DDIM step's model call of a composed sampler: ∅ + 2 concepts = 3 × batch rows."""
    torch.manual_seed(0)
    model = LatentDenoiser(**{**denoiser_kwargs(PipelineConfig()), "width": width,
                              "layers": layers}).eval()
    latents, text, mask = _latent_inputs()
    rows = torch.arange(3 * batch) % 512
    x, c, m, t = latents[rows], text[rows], mask[rows], torch.full((3 * batch,), 500)

    def run(steps: int) -> float:
        start = time.perf_counter()
        with torch.no_grad():
            for _ in range(steps):
                model(x, t, c, m)
        return time.perf_counter() - start
    return run


def evaluator_training(dim: int, hidden: int, frames: int) -> Callable[[int], float]:
    motions = smooth_signals(256, 263, frames, seed=4).transpose(1, 2).numpy().copy()
    lengths = np.full(256, frames)
    words = ("walk", "run", "jump", "wave", "clap", "squat", "turn", "left", "right", "slowly")
    captions = [f"a person {words[i % 10]} {words[(i // 10) % 10]}" for i in range(256)]

    def run(steps: int) -> float:
        config = EvaluatorConfig(dim=dim, hidden=hidden, steps=steps)
        start = time.perf_counter()
        train_evaluator(motions, lengths, captions, config)
        return time.perf_counter() - start
    return run


def rows(quick: bool) -> Iterator[tuple[Row, Callable[[int], float]]]:
    """(description, timed loop) of every measurement."""
    small = {"batches": (8,), "frames": (16,)} if quick else {"batches": (32, 64),
                                                              "frames": (48, 24)}
    motion = [(288, (1, 0.5, 0.25))] + [(b, m) for b in (64, 96, 128) for m in ((1, 1), (1, 2))]
    if quick:
        motion = [(16, (1, 1))]
    for base, mults in motion:
        for frames in small["frames"]:
            for batch in small["batches"]:
                if base == 288 and (frames, batch) != (48, 64) and not quick:
                    continue
                for name, autocast in PRECISIONS.items():
                    yield ({"family": "motion_unet", "what": "train", "base": base,
                            "mults": list(mults), "frames": frames, "batch": batch,
                            "precision": name},
                           unet_training(263, base, mults, frames, batch, autocast))
    if not quick:   # the text condition of GMD-B3/C4's models (bag of words)
        for base, mults in ((288, (1, 0.5, 0.25)), (128, (1, 1)), (64, (1, 2))):
            yield ({"family": "motion_unet_text", "what": "train", "base": base,
                    "mults": list(mults), "frames": 48, "batch": 64, "precision": "fp32"},
                   unet_training(263, base, mults, 48, 64, None, COND_DIM))
    trajectory = [(64, (1, 2, 4), 64)] + [(b, m, n) for b in (16, 32)
                                         for m in ((1, 2, 4), (1, 2)) for n in (64, 32)]
    for base, mults, batch in [(16, (1, 2, 4), 8)] if quick else trajectory:
        for name, autocast in PRECISIONS.items():
            frames = 16 if quick else 48
            yield ({"family": "trajectory_unet", "what": "train", "base": base,
                    "mults": list(mults), "frames": frames, "batch": batch, "precision": name},
                   unet_training(4, base, mults, frames, batch, autocast))
    sampled = [(263, 288, (1, 0.5, 0.25)), (263, 128, (1, 1)), (263, 64, (1, 2)),
               (263, 96, (1, 1)), (263, 64, (1, 1)), (4, 64, (1, 2, 4)), (4, 32, (1, 2, 4)),
               (4, 16, (1, 2, 4)), (4, 16, (1, 2))]
    for channels, base, mults in sampled[-1:] if quick else sampled:
        for batch in small["batches"]:
            for guided in ((False, True) if channels == 4 else (False,)):
                for name, autocast in PRECISIONS.items():
                    yield ({"family": "motion_unet" if channels == 263 else "trajectory_unet",
                            "what": "guided_step" if guided else "sample_step", "base": base,
                            "mults": list(mults), "frames": small["frames"][0],
                            "batch": batch, "precision": name},
                           unet_sampling(channels, base, mults, small["frames"][0], batch,
                                         autocast, guided))
    vae_frames, vae_batch, denoiser_batch = (16, 8, 16) if quick else (64, 32, 128)
    for width in (64, 32):
        yield ({"family": "vae", "what": "train", "width": width, "layers": 2,
                "frames": vae_frames, "batch": vae_batch, "precision": "fp32"},
               vae_training(width, vae_batch, vae_frames))
    for width, layers in ((64, 3), (32, 3), (32, 2)):
        for name, autocast in PRECISIONS.items():
            yield ({"family": "latent_denoiser", "what": "train", "width": width,
                    "layers": layers, "batch": denoiser_batch, "precision": name},
                   denoiser_training(width, layers, denoiser_batch, autocast))
        yield ({"family": "latent_denoiser", "what": "sample_step_composed", "width": width,
                "layers": layers, "batch": 32, "precision": "fp32"},
               denoiser_sampling(width, layers, 32))
    evaluators = [(64, 128, 48), (32, 64, 64), (32, 64, 48), (16, 32, 48)]
    for dim, hidden, frames in evaluators[:1] if quick else evaluators:
        yield ({"family": "evaluator", "what": "train", "dim": dim, "hidden": hidden,
                "frames": frames, "batch": 64, "precision": "fp32"},
               evaluator_training(dim, hidden, frames))


def _cpu() -> str:
    """The CPU's model name and whether it has AMX / AVX-512 bf16 (bf16 autocast pays only
    with them), from /proc/cpuinfo; ``platform.machine()`` where that is not readable."""
    try:
        info = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.machine()
    name = next((line.split(":", 1)[1].strip() for line in info.splitlines()
                 if line.startswith("model name")), platform.machine())
    flags = set(next((line.split(":", 1)[1].split() for line in info.splitlines()
                      if line.startswith("flags")), []))
    return f"{name}; amx_bf16 {'amx_bf16' in flags}, avx512_bf16 {'avx512_bf16' in flags}"


def _key(row: Row) -> str:
    """A row's description without its measurement (what ``--out`` matches rows by)."""
    return json.dumps({k: v for k, v in row.items() if k not in ("ms_per_step", "steps_timed")},
                      sort_keys=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes, one step each")
    parser.add_argument("--seconds", type=float, default=2.5, help="timed seconds per row")
    parser.add_argument("--only", default=None, help="only rows whose family contains this")
    parser.add_argument("--out", type=Path, default=None,
                        help="also write the JSON lines here; rows it already holds are kept "
                             "and not measured again (a later run appends under a new header)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    header = {"cpu": _cpu(), "torch": torch.__version__, "threads": torch.get_num_threads(),
              "when": time.strftime("%Y-%m-%d %H:%M")}
    lines = [json.dumps({"header": header})]
    print(lines[0], flush=True)
    done: set[str] = set()   # rows an earlier run wrote to --out: kept, not measured again
    if args.out is not None and args.out.exists():
        earlier = args.out.read_text().splitlines()
        lines = earlier + lines
        done = {_key(json.loads(line)) for line in earlier if "header" not in line}
    for row, run in rows(args.quick):
        if (args.only and args.only not in row["family"]) or _key(row) in done:
            continue
        seconds, steps = _per_step(run, args.seconds, args.quick,
                                   setup_included=row["family"] == "evaluator")
        row.update(ms_per_step=round(1000 * seconds, 2), steps_timed=steps)
        lines.append(json.dumps(row))
        print(lines[-1], flush=True)
    if args.out is not None:
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
