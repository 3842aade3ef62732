"""Pilot for the standard scale (issue #32, docs/COMPUTE.md §9): the latent denoiser's fitness
gate (gates version 3, family ``latent_denoiser``: held-out x̂0 error ≤ 0.9× that of the best
Gaussian denoiser, ``core.fitness.x0_error_ratio``) along training, for the standard design
(width 32 × 2 layers) and others (e.g. the paper's 64 × 3), and what a step costs here.

The standard pipeline of evaluation seed ``--seed`` (``pipeline_config("standard")``: its VAE,
900 fixed steps, and the frozen MiniLM text stage, both from the cache after the first build;
N = 5) gives the training rows (``pipeline.denoiser_rows``) and the plan's validation rows
(``pipeline.validation_rows``, 128 clips). The denoiser of ``--width`` × ``--layers`` (lr
``--lr``; ``--dropout``, default the package's 0.1) trains with the standard plan's
configuration (``pipeline.denoiser_train_config``: batch 128, AdamW, EMA 0.999 with warm-up,
text dropped 10 %, validated every 250 steps, no plateau stop) to a fixed ``--steps``, through
``core.training.train_diffusion`` and its ``on_validation`` hook (the loop
``models.latent_denoiser.train_latent_denoiser`` runs, with the same packing of the text; the
hook draws nothing from the training generator, so the first 1000 steps of 32 × 2 are the
standard pipeline's denoiser). Initialisation as ``pipeline.train_denoiser_stage``.

Every ``--gate-every`` steps (a multiple of 250): the gate value exactly as the notebooks
measure it (``model_gates.denoiser_gate_values`` on the ``gate_test_clips`` = 256 held-out
text-to-motion test clips, seed ``gate_seed`` = the evaluation seed) of the EMA weights (what
the cache keeps) and of the raw weights, and, for the measurement's soundness, the same ratio
per noise level, with the null text instead of the captions, and on 256 training clips
(in-sample) instead of the test clips; the Gaussian denoiser's error relative to the
latents' total variance; the EMA validation loss; the training CPU seconds
(``time.process_time``, one torch thread, without the gate checks; with and without the
plan's validation). One JSON line per check goes to ``--out`` (appended). The rows of
docs/pilot_standard_denoiser.jsonl::

    OMP_NUM_THREADS=1 PYTHONPATH=src python scripts/pilot_standard_denoiser.py \
        --width 32 --layers 2 --steps 4000 --gate-every 500 \
        --out docs/pilot_standard_denoiser.jsonl
    OMP_NUM_THREADS=1 PYTHONPATH=src python scripts/pilot_standard_denoiser.py \
        --width 64 --layers 3 --steps 4000 --gate-every 500 \
        --out docs/pilot_standard_denoiser.jsonl
    OMP_NUM_THREADS=1 PYTHONPATH=src python scripts/pilot_standard_denoiser.py \
        --width 64 --layers 2 --steps 2500 --gate-every 500 \
        --out docs/pilot_standard_denoiser.jsonl
    OMP_NUM_THREADS=1 PYTHONPATH=src python scripts/pilot_standard_denoiser.py \
        --width 64 --layers 2 --seed 1 --steps 1500 --gate-every 500 \
        --out docs/pilot_standard_denoiser.jsonl

(The first two runs' rows lack the ``latent_*`` spectrum fields, added after they started.)
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from torch import Tensor, nn

from repro.core import fitness
from repro.core.gates import GATES, GATES_VERSION
from repro.core.training import ValidationSet, train_diffusion
from repro.energymogen.config import pipeline_config
from repro.energymogen.convergence import TrainingPlan
from repro.energymogen.data import load_or_build_data
from repro.energymogen.harness import TextToMotionTest, load_or_build_text_to_motion_test
from repro.energymogen.model_gates import denoiser_gate_values, gate_seed
from repro.energymogen.pipeline import (
    EnergyMoGenPipeline,
    denoiser_kwargs,
    denoiser_rows,
    denoiser_train_config,
    latent_diffusion,
    train_seed_for,
    train_vae_stage,
    validation_clips,
    validation_rows,
)
from repro.energymogen.settings import AugmentationSettings
from repro.energymogen.text_stage import train_text_stage
from repro.models.latent_denoiser import LatentDenoiser, _PackedTextAdapter


def packed(tokens: Tensor, mask: Tensor) -> Tensor:
    """The text as ``train_latent_denoiser`` packs it for ``train_diffusion``: (B, L, D + 1)."""
    return torch.cat([tokens.float(), mask[..., None].float()], dim=-1)


def standard_pipeline(args: argparse.Namespace):
    """The standard pipeline's parts for evaluation seed ``args.seed`` (no denoiser, no
    evaluator: neither is measured here), the design's config, plan and training rows."""
    base = replace(pipeline_config("standard"), latent_count=args.latents)
    config = replace(base, denoiser_width=args.width, denoiser_layers=args.layers,
                     denoiser_lr=args.lr)
    plan = TrainingPlan.for_scale("standard")
    data = load_or_build_data(base)
    train_seed = train_seed_for(base, args.seed)
    reference_vae = train_vae_stage(data, base, base.data_seed, plan=plan, threads=1)
    vae = reference_vae if train_seed == base.data_seed else train_vae_stage(
        data, base, train_seed, plan=plan, threads=1)
    text = train_text_stage(data, base, reference_vae.latents, base.data_seed)
    pipe = EnergyMoGenPipeline(base, data, vae.vae, text.text_encoder, text.vocab,
                               None, latent_diffusion(base), None, vae.latent_scale, None,
                               torch.device("cpu"), train_seed=train_seed, plan=plan)
    rows = denoiser_rows(data, vae.latents, text.text_encoder, text.vocab, config)
    val = validation_rows(data, validation_clips(base, plan), vae, text, base)
    return pipe, config, plan, rows, val


class Diagnostics:
    """The soundness checks beside the gate value (all with the gate's seed and levels)."""

    def __init__(self, pipe: EnergyMoGenPipeline, test: TextToMotionTest, seed: int) -> None:
        self.pipe, self.seed = pipe, seed
        train = pipe.encode_motion(pipe.data.train_features)
        self.train_std = float(train.std())
        self.mean, self.cov = fitness.gaussian_fit(train.reshape(len(train), -1))
        self.total_variance = float(np.trace(self.cov))
        self.z_test = pipe.encode_motion(test.features)
        self.text_test = pipe.encode(test.texts(seed))
        count = len(test)
        rng = np.random.default_rng([seed, 808])
        pick = np.sort(rng.choice(len(pipe.data.train_features), count, replace=False))
        self.z_train = train[pick]
        captions = [pipe.data.train_captions[i] for i in pick]
        self.text_train = pipe.encode([c[int(rng.integers(len(c)))] for c in captions])

    def ratio(self, model: nn.Module, z0: Tensor, text: tuple[Tensor, Tensor] | None,
              levels: tuple[float, ...] = fitness.NOISE_LEVELS) -> float:
        diffusion = self.pipe.diffusion

        def predict_x0(z_t: Tensor, t: Tensor) -> Tensor:
            tokens, mask = model.null_text(len(z_t)) if text is None else text
            return diffusion.predict_x0_from_eps(z_t, t, model(z_t, t, tokens, mask))

        with torch.random.fork_rng(devices=[]):
            return fitness.x0_error_ratio(predict_x0, diffusion.alphas_cumprod, z0,
                                          lambda z: z.reshape(len(z), -1), self.mean,
                                          self.cov, seed=self.seed, levels=levels)

    def gaussian_fraction(self, z0: Tensor, level: float) -> float:
        """The Gaussian denoiser's mean squared x̂0 error over the latents' total variance."""
        a = float(self.pipe.diffusion.alphas_cumprod[
            fitness.level_timesteps(self.pipe.diffusion.alphas_cumprod, (level,))[0]])
        generator = torch.Generator().manual_seed(self.seed)
        truth = z0.reshape(len(z0), -1).double().numpy()
        noise = torch.randn(truth.shape, generator=generator, dtype=torch.float64).numpy()
        x_t = np.sqrt(a) * truth + np.sqrt(1 - a) * noise
        error = ((fitness.gaussian_x0(x_t, a, self.mean, self.cov) - truth) ** 2).sum(1).mean()
        return float(error / self.total_variance)

    def values(self, model: nn.Module) -> dict[str, float]:
        out = {"ratio_null_text": self.ratio(model, self.z_test, None),
               "ratio_train_clips": self.ratio(model, self.z_train, self.text_train)}
        for level in fitness.NOISE_LEVELS:
            out[f"ratio_at_{level}"] = self.ratio(model, self.z_test, self.text_test, (level,))
        return out

    def static(self) -> dict[str, float]:
        eigen = np.sort(np.linalg.eigvalsh(self.cov))[::-1]
        share = np.cumsum(eigen) / eigen.sum()
        return {"latent_std_train": self.train_std, "latent_total_variance": self.total_variance,
                "latent_dims": len(eigen),
                "latent_participation_ratio": float(eigen.sum() ** 2 / (eigen ** 2).sum()),
                "latent_dims_for_90pct_variance": int(np.searchsorted(share, 0.9) + 1),
                "latent_dims_for_99pct_variance": int(np.searchsorted(share, 0.99) + 1),
                "latent_dims_with_variance_below_0.01": int((eigen < 0.01).sum()),
                "latent_std_test": float(self.z_test.std()),
                **{f"gaussian_error_fraction_test_at_{level}":
                   self.gaussian_fraction(self.z_test, level) for level in fitness.NOISE_LEVELS},
                **{f"gaussian_error_fraction_train_at_{level}":
                   self.gaussian_fraction(self.z_train, level) for level in fitness.NOISE_LEVELS}}


def run(args: argparse.Namespace) -> None:
    pipe, config, plan, rows, val = standard_pipeline(args)
    gate_test_clips = AugmentationSettings.for_scale("standard").gate_test_clips
    test = load_or_build_text_to_motion_test(pipe.config, gate_test_clips)
    seed = gate_seed(pipe)
    diagnostics = Diagnostics(pipe, test, seed)
    static = diagnostics.static()
    print(json.dumps(static), flush=True)
    pilot_plan = replace(plan, denoiser_step_cap=args.steps)
    train_config = denoiser_train_config(config, pipe.train_seed, threads=1, plan=pilot_plan)
    torch.manual_seed(int(pipe.train_seed))                 # as train_denoiser_stage builds it
    extra = {} if args.dropout is None else {"dropout": args.dropout}
    denoiser = LatentDenoiser(**denoiser_kwargs(config), **extra)
    params = sum(p.numel() for p in denoiser.parameters())
    adapter = _PackedTextAdapter(denoiser)
    validation = ValidationSet(val.latents.float(), cond=packed(val.tokens, val.mask))
    bound = GATES["latent_denoiser"][0].at_most
    clock = {"start": time.process_time(), "checks": 0.0, "first_validation": None}
    wall = time.perf_counter()

    def on_validation(steps: int, loss: float, ema: nn.Module) -> None:
        now = time.process_time()
        if clock["first_validation"] is None:
            clock["first_validation"] = now - clock["start"]
        if steps == 0 or steps % args.gate_every and steps != args.steps:
            return
        train_cpu = now - clock["start"] - clock["checks"]
        evaluations = steps // plan.denoiser_validate_every + 1
        pure = train_cpu - evaluations * clock["first_validation"]
        ema_denoiser = ema.denoiser
        ema_value = denoiser_gate_values(pipe, test, seed, denoiser=ema_denoiser)
        denoiser.eval()
        raw_value = denoiser_gate_values(pipe, test, seed, denoiser=denoiser)
        denoiser.train()
        ratio = ema_value["x0_error_vs_gaussian"]
        row = {"pilot": "standard_denoiser", "gates_version": GATES_VERSION,
               "width": args.width, "layers": args.layers, "dropout": denoiser.dropout,
               "params": params,
               "latent_count": pipe.config.latent_count, "batch": train_config.batch_size,
               "lr": train_config.lr, "ema_decay": train_config.ema_decay, "seed": args.seed,
               "train_seed": pipe.train_seed, "gate_seed": seed, "steps": steps,
               "test_clips": len(test), "bound": bound, "x0_error_vs_gaussian": ratio,
               "passes": ratio <= bound, "x0_error_vs_gaussian_raw_weights":
               raw_value["x0_error_vs_gaussian"], **diagnostics.values(ema_denoiser),
               "validation_loss": loss, "train_cpu_seconds": train_cpu,
               "cpu_ms_per_step": 1000 * train_cpu / steps,
               "cpu_ms_per_step_without_validation": 1000 * pure / steps,
               "validation_cpu_seconds": clock["first_validation"],
               "wall_seconds": time.perf_counter() - wall, "threads": 1, "dtype": "float32",
               **static}
        print(json.dumps(row), flush=True)
        with args.out.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        clock["checks"] += time.process_time() - now

    clock["start"] = time.process_time()
    train_diffusion(adapter, pipe.diffusion, rows.latents.float(), train_config,
                    cond=packed(rows.tokens, rows.mask), validation=validation,
                    on_validation=on_validation, progress=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=32)
    parser.add_argument("--layers", type=int, default=2)
    parser.add_argument("--lr", type=float, default=pipeline_config("standard").denoiser_lr)
    parser.add_argument("--dropout", type=float, default=None,
                        help="the denoiser's dropout (default: LatentDenoiser's, 0.1)")
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--gate-every", type=int, default=500,
                        help="a multiple of the plan's validation interval (250)")
    parser.add_argument("--seed", type=int, default=0,
                        help="evaluation seed (training seed ``pipeline.train_seed_for``)")
    parser.add_argument("--latents", type=int, default=pipeline_config("standard").latent_count,
                        help="N, the VAE's latent vectors (EMG-7's other standard N is 7)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if args.gate_every % TrainingPlan.for_scale("standard").denoiser_validate_every:
        parser.error("--gate-every must be a multiple of 250")
    torch.set_num_threads(1)
    run(args)


if __name__ == "__main__":
    main()
