"""``python -m repro bench --training``: training and sampling speed per model family, against
this machine's GEMM peaks measured in the same run.

For each family (GMD UNet trajectory (4 ch) and motion (263 ch), the motion VAE, the latent
denoiser, the evaluator), at the sizes the package trains it with:

- samples/s of a plain fp32 eager loop kept here as the baseline (per-parameter AdamW, clip and
  EMA loops, torch's Mish) and of the package's configuration (``train_diffusion`` /
  ``train_latent_denoiser`` / ``train_vae`` / ``train_evaluator`` at their defaults), measured
  in adjacent pairs (A/B/A/B: the machine is shared, absolute rates are noisy, adjacent ratios
  much less) and reported as the median of the per-pair ratios;
- GFLOP per step from ``torch.utils.flop_counter.FlopCounterMode`` (matrix products,
  convolutions and attention, forward + backward) and the achieved GFLOP/s = GFLOP/step ×
  steps/s of the package configuration, as fractions of the fp32 and bf16 GEMM peaks;
- the opt-in levers (``FastMish``, fused AdamW, bf16 autocast) where the family's training
  takes them, each as a ratio against the same baseline;
- the time to pass the family's quality gate: null, the synthetic signals have no gate
  (``GATE_NOTE``).

Also fp32 against bf16 autocast for the motion UNet at base 16, at width 288 (mults 1-1-1,
wide enough for 263-d ε) and as the notebooks train it in full mode (``notebook_motion``:
``MOTION_ARCHITECTURE`` at ``MOTION_TRAINING``'s batch 64, whose bf16 decision is
pilots/pilot_bf16_motion.md), the exact-math levers alone (FastMish forward + backward and
forward only; the parameter update as loops, foreach and fused: a whole step's noise on a
shared machine hides a 5–10 % gain), a numerics pilot (validation loss of each lever's run
against fp32's after the same steps, tolerance ``PILOT_TOLERANCE``), and samples/s of the DDPM
and DDIM loops per diffusion family at two batch sizes (the gain from batching seeds and
items together).

Data are synthetic (smooth random signals, random latents and text tokens): speed does not
depend on the values. Writes the keys ``training``, ``training_bench`` and ``sampling`` of
``build/bench/bench.json``, keeping every other key, atomically.

Threads: 2 by default (the machine the budgets are for). On a machine other processes load, two
OpenMP threads spin-wait for each other: one measured run took 18 min with ratios from 0.07
to 5.7, against 3 min and 0.6–1.9 with ``--threads 1``; the JSON records the load average.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import torch
from torch import Tensor, nn
from torch.utils.flop_counter import FlopCounterMode

from repro.core.diffusion import GaussianDiffusion
from repro.core.training import TrainConfig, train_diffusion
from repro.gmd.models import MOTION_ARCHITECTURE, MOTION_TRAINING, GMDModelSpec, schedule_diffusion
from repro.infra import paths
from repro.infra.storage import read_json, write_json
from repro.models.unet import UNet1D
from repro.run.bench_families import (
    FULL,
    QUICK,
    BenchSizes,
    Family,
    all_families,
    seconds_of,
    smooth_signals,
)

__all__ = ["FULL", "PILOT_TOLERANCE", "QUICK", "BenchSizes", "bench_training", "main"]

#: a lever's validation loss may differ from fp32's by this fraction (pilot, stated up front)
PILOT_TOLERANCE = 0.05
GATE_NOTE = ("not measured here: the bench trains on synthetic signals, which have no gate; "
             "each model's gate is measured where a notebook trains it (results/models.json, "
             "steps and training time beside it)")


# ---------------------------------------------------------------------------------------------
# Timing helpers
# ---------------------------------------------------------------------------------------------


def gemm_peak_gflops(n: int, dtype: torch.dtype, repeats: int = 10) -> float:
    """Best GFLOP/s of an (n × n) @ (n × n) product (2n³ flops) in ``dtype``."""
    g = torch.Generator().manual_seed(0)
    a = torch.randn(n, n, generator=g).to(dtype)
    b = torch.randn(n, n, generator=g).to(dtype)
    a @ b
    best = min(seconds_of(lambda: a @ b) for _ in range(repeats))
    return 2.0 * n ** 3 / best / 1e9


def step_gflop(run_one_step: Callable[[], Any]) -> float:
    """GFLOP that ``FlopCounterMode`` counts in one call (a forward + backward step)."""
    counter = FlopCounterMode(display=False)
    with counter:
        run_one_step()
    return counter.get_total_flops() / 1e9


def paired_ratios(baseline: Callable[[int], float], candidate: Callable[[int], float],
                  steps: int, repeats: int) -> dict[str, Any]:
    """Time ``steps`` steps of baseline then candidate, ``repeats`` times (A/B/A/B); each
    callable returns its loop's seconds. Ratio = baseline seconds / candidate seconds."""
    baseline(1)
    candidate(1)                                   # warm-up: allocator, oneDNN primitives
    a: list[float] = []
    b: list[float] = []
    for _ in range(repeats):
        a.append(baseline(steps))
        b.append(candidate(steps))
    ratios = [x / y for x, y in zip(a, b, strict=True)]
    return {"baseline_seconds": a, "candidate_seconds": b, "ratios": ratios,
            "ratio": statistics.median(ratios)}


# ---------------------------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------------------------


def _family_row(family: Family, sizes: BenchSizes) -> dict[str, Any]:
    gflop = step_gflop(lambda: family.baseline(1))
    main_pair = paired_ratios(family.baseline, family.package, sizes.steps, sizes.repeats)
    package_rate = sizes.steps * family.batch / statistics.median(main_pair["candidate_seconds"])
    baseline_rate = sizes.steps * family.batch / statistics.median(main_pair["baseline_seconds"])
    gflops = gflop * package_rate / family.batch
    levers = {}
    for name, run in family.levers.items():
        pair = paired_ratios(family.baseline, run, sizes.steps, sizes.repeats)
        levers[name] = {"ratio_vs_fp32_eager": pair["ratio"], "ratios": pair["ratios"]}
    return {"sizes": family.sizes, "baseline_samples_per_s": baseline_rate,
            "package_samples_per_s": package_rate,
            "ratio_vs_fp32_eager": main_pair["ratio"], "ratios": main_pair["ratios"],
            "gflop_per_step": gflop, "gflops": gflops,
            "levers": levers, "seconds_to_gate": None, "gate": GATE_NOTE}


def _width_study(sizes: BenchSizes) -> dict[str, Any]:
    """fp32 against bf16 autocast (the package loop) for the motion UNet, narrow and wide."""
    spec = GMDModelSpec(task="motion")
    frames = sizes.frames or spec.data.frames
    diffusion = schedule_diffusion(spec.schedule, sizes.timesteps or spec.diffusion_steps,
                                   spec.prediction)
    data = smooth_signals(sizes.data_items, spec.channels, frames, seed=5)
    wide_steps = max(1, sizes.steps // 4)
    #: name → (width, mults, batch, steps per measurement)
    batch = sizes.batch or spec.training.batch_size
    cases = {"base16": (spec.base_channels, spec.channel_mults, batch, sizes.steps),
             f"width{sizes.wide_width}": (sizes.wide_width, (1.0, 1.0, 1.0), sizes.wide_batch,
                                          wide_steps),
             "notebook_motion": (sizes.wide_width, MOTION_ARCHITECTURE.channel_mults,
                                 sizes.batch or MOTION_TRAINING.batch_size, sizes.steps)}
    out = {}
    for name, (width, mults, batch, steps) in cases.items():
        def loop(autocast: str | None, width: int = width, mults: tuple = mults,
                 batch: int = batch) -> Callable[[int], float]:
            return lambda n: train_diffusion(
                _seeded(lambda: UNet1D(spec.channels, width, mults)), diffusion, data,
                TrainConfig(steps=n, batch_size=batch, lr=spec.training.lr, seed=0,
                            autocast=autocast),
                progress=False).seconds

        pair = paired_ratios(loop(None), loop("bfloat16"), steps, sizes.repeats)
        out[name] = {"model": f"UNet1D({spec.channels}, base {width}, mults {list(mults)})",
                     "batch": batch, "frames": frames, "steps_per_measurement": steps,
                     "fp32_ms_per_step": 1e3 * statistics.median(pair["baseline_seconds"]) / steps,
                     "bf16_ms_per_step": 1e3 * statistics.median(pair["candidate_seconds"]) / steps,
                     "bf16_speedup": pair["ratio"], "ratios": pair["ratios"]}
    return out


def _seeded(build: Callable[[], nn.Module]) -> nn.Module:
    torch.manual_seed(0)
    return build()


def _sample_seconds(diffusion: GaussianDiffusion, loop: str, model: nn.Module,
                    shape: tuple[int, ...], kwargs: dict[str, Any], ddim_steps: int) -> float:
    if loop == "ddpm":
        return seconds_of(lambda: diffusion.p_sample_loop(model, shape, model_kwargs=kwargs,
                                                        seed=0))
    return seconds_of(lambda: diffusion.ddim_sample_loop(model, shape, steps=ddim_steps,
                                                       model_kwargs=kwargs, seed=0))


def _isolated_levers(sizes: BenchSizes) -> dict[str, Any]:
    """The exact-math levers alone on the motion UNet (base 16), where a whole training step's
    noise would hide them: forward + backward and forward only with ``FastMish`` against
    ``nn.Mish``; the parameter update (AdamW + clip + EMA) as loops, foreach, fused."""
    spec = GMDModelSpec(task="motion")
    frames, batch = sizes.frames or spec.data.frames, sizes.batch or spec.training.batch_size
    pairs, calls = 4 * sizes.repeats, max(1, sizes.steps - 1)
    plain = _seeded(lambda: UNet1D(spec.channels, spec.base_channels, spec.channel_mults))
    fast = UNet1D(spec.channels, spec.base_channels, spec.channel_mults, fast_mish=True)
    fast.load_state_dict(plain.state_dict())
    x = smooth_signals(batch, spec.channels, frames, seed=8)
    t = torch.arange(batch) % spec.diffusion_steps

    def step(model: nn.Module) -> Callable[[int], float]:
        def run(n: int) -> float:
            def once() -> None:
                model.zero_grad(set_to_none=True)
                model(x, t).pow(2).mean().backward()
            return sum(seconds_of(once) for _ in range(n))
        return run

    def forward(model: nn.Module) -> Callable[[int], float]:
        def run(n: int) -> float:
            with torch.no_grad():
                return sum(seconds_of(lambda: model(x, t)) for _ in range(n))
        return run

    plain(x, t).pow(2).mean().backward()                 # gradients for the update timings
    params = list(plain.parameters())
    ema = [p.detach().clone() for p in params]

    def update(kind: str) -> Callable[[int], float]:
        optimizer = torch.optim.AdamW(params, lr=1e-9, foreach=kind == "foreach",
                                      fused=True if kind == "fused" else None)

        def once() -> None:
            nn.utils.clip_grad_norm_(params, 1e9, foreach=kind != "loop")
            optimizer.step()
            with torch.no_grad():
                if kind == "loop":
                    for e, p in zip(ema, params, strict=True):
                        e.lerp_(p, 1e-4)
                else:
                    torch._foreach_lerp_(ema, params, 1e-4)

        return lambda n: sum(seconds_of(once) for _ in range(n))

    out: dict[str, Any] = {"model": f"UNet1D(263, base 16, mults [1, 2, 4]), batch {batch}, "
                                    f"{frames} frames", "pairs": pairs, "calls_per_pair": calls}
    for name, (a, b) in {"fast_mish_forward_backward": (step(plain), step(fast)),
                         "fast_mish_forward": (forward(plain), forward(fast)),
                         "update_foreach_vs_loop": (update("loop"), update("foreach")),
                         "update_fused_vs_loop": (update("loop"), update("fused"))}.items():
        pair = paired_ratios(a, b, calls, pairs)
        out[name] = {"ratio": pair["ratio"],
                     "baseline_ms": 1e3 * statistics.median(pair["baseline_seconds"]) / calls,
                     "candidate_ms": 1e3 * statistics.median(pair["candidate_seconds"]) / calls}
    return out


def _validation_loss(model: nn.Module, diffusion: GaussianDiffusion, data: Tensor) -> float:
    g = torch.Generator().manual_seed(1)
    t = torch.randint(0, diffusion.num_timesteps, (data.shape[0],), generator=g)
    noise = torch.randn(data.shape, generator=g)
    with torch.no_grad():
        return float(diffusion.training_losses(model.eval(), data, t, noise=noise).mean())


def _pilot(sizes: BenchSizes) -> dict[str, Any]:
    """Train the motion UNet the same steps in fp32 and with each lever; compare the
    validation loss (fp32 evaluation of the trained weights on held-out windows).

    At FULL's 40 steps the loss has barely left 1 (the untrained ε loss), so agreement there
    is weak evidence; before adopting bf16 where it pays (AMX), run ``--pilot-steps`` in the
    thousands and compare the family's gate values too."""
    spec = GMDModelSpec(task="motion")
    frames = sizes.frames or spec.data.frames
    batch = sizes.pilot_batch
    diffusion = schedule_diffusion(spec.schedule, sizes.timesteps or spec.diffusion_steps,
                                   spec.prediction)
    train = smooth_signals(sizes.data_items, spec.channels, frames, seed=6)
    held_out = smooth_signals(max(8, sizes.data_items // 4), spec.channels, frames, seed=7)
    runs = {"fp32": {}, "bf16_autocast": {"autocast": "bfloat16"},
            "fast_mish+fused_adamw": {"fused_adamw": True, "fast_mish": True}}
    losses = {}
    for name, levers in runs.items():
        levers = dict(levers)
        fast_mish = levers.pop("fast_mish", False)
        torch.manual_seed(0)
        model = UNet1D(spec.channels, spec.base_channels, spec.channel_mults,
                       fast_mish=fast_mish)
        config = TrainConfig(steps=sizes.pilot_steps, batch_size=batch, lr=spec.training.lr, seed=0,
                             **levers)
        result = train_diffusion(model, diffusion, train, config, progress=False)
        losses[name] = _validation_loss(result.model, diffusion, held_out)
    out: dict[str, Any] = {"model": "UNet1D(263, base 16, mults [1, 2, 4])",
                           "steps": sizes.pilot_steps, "batch": batch, "tolerance": PILOT_TOLERANCE,
                           "validation_loss": losses}
    for name in runs:
        if name != "fp32":
            relative = abs(losses[name] - losses["fp32"]) / losses["fp32"]
            out[name] = {"relative_difference": relative,
                         "within_tolerance": relative <= PILOT_TOLERANCE}
    return out


def _sampling(families: Sequence[Family], sizes: BenchSizes) -> dict[str, Any]:
    """samples/s of ``p_sample_loop`` (all T steps) and ``ddim_sample_loop`` per family."""
    out = {}
    for family in families:
        if family.sampler is None or family.diffusion is None:
            continue
        diffusion = family.diffusion
        row: dict[str, Any] = {"diffusion_steps": diffusion.num_timesteps,
                               "ddim_steps": sizes.ddim_steps}
        for loop in ("ddpm", "ddim"):
            for batch in sizes.sample_batches:
                model = family.sampler(batch)
                kwargs = family.model_kwargs(batch) if family.model_kwargs else {}
                shape = (batch, *family.sample_shape)
                seconds = statistics.median(
                    _sample_seconds(diffusion, loop, model, shape, kwargs, sizes.ddim_steps)
                    for _ in range(max(1, sizes.repeats - 1)))
                row[f"{loop}_samples_per_s_batch{batch}"] = batch / seconds
            small, large = sizes.sample_batches
            row[f"{loop}_batching_gain"] = (row[f"{loop}_samples_per_s_batch{large}"]
                                            / row[f"{loop}_samples_per_s_batch{small}"])
        out[family.name] = row
    return out


def _cpu_flags() -> list[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return []
    flags = next((line.split(":", 1)[1].split() for line in text.splitlines()
                  if line.startswith("flags")), [])
    return sorted(f for f in flags if f.startswith(("amx", "avx512_bf16", "avx512f")))


def _commit() -> str | None:
    done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=paths.REPO_ROOT,
                          capture_output=True, text=True, check=False)
    return done.stdout.strip() or None


def _peaks(n: int, earlier: dict[str, Any] | None = None) -> dict[str, Any]:
    """fp32 and bf16 GEMM GFLOP/s; with ``earlier``, the larger of the two measurements (the
    peak is measured at the start and at the end: a loaded moment lowers only one)."""
    peaks = {"fp32_gflops": gemm_peak_gflops(n, torch.float32),
             "bf16_gflops": gemm_peak_gflops(n, torch.bfloat16), "gemm_n": n}
    if earlier is not None:
        for key in ("fp32_gflops", "bf16_gflops"):
            peaks[key] = max(peaks[key], earlier[key])
    return peaks


def _progress(what: str, start: float) -> None:
    print(f"[{time.perf_counter() - start:5.0f} s] {what} ...", file=sys.stderr, flush=True)


def bench_training(*, quick: bool = False, threads: int = 2, out: str | Path | None = None,
                   pilot_steps: int | None = None) -> dict[str, Any]:
    """Measure every section, merge ``training``, ``training_bench`` and ``sampling`` into
    ``out`` (default ``build/bench/bench.json``) and return those three sections."""
    sizes = QUICK if quick else FULL
    if pilot_steps is not None:
        if pilot_steps < 1:
            raise ValueError(f"pilot_steps must be >= 1, got {pilot_steps}")
        sizes = dataclasses.replace(sizes, pilot_steps=pilot_steps)
    out = Path(out) if out is not None else paths.build_root() / "bench" / "bench.json"
    previous_threads = torch.get_num_threads()
    torch.set_num_threads(threads)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    try:
        with torch.random.fork_rng(devices=[]):
            peaks = _peaks(sizes.gemm_n)
            families = all_families(sizes)
            training = {}
            for family in families:
                _progress(f"training: {family.name}", start)
                training[family.name] = _family_row(family, sizes)
            _progress("fp32 against bf16 at base 16 and wide", start)
            width_study = _width_study(sizes)
            _progress("isolated levers", start)
            isolated = _isolated_levers(sizes)
            _progress("numerics pilot", start)
            pilot = _pilot(sizes)
            _progress("sampling", start)
            sampling = _sampling(families, sizes)
            _progress("GEMM peaks again", start)
            peaks = _peaks(sizes.gemm_n, peaks)
            for row in training.values():
                row["fraction_of_fp32_peak"] = row["gflops"] / peaks["fp32_gflops"]
                row["fraction_of_bf16_peak"] = row["gflops"] / peaks["bf16_gflops"]
    finally:
        torch.set_num_threads(previous_threads)
    meta = {"mode": "quick" if quick else "full", "threads": threads, "sizes": asdict(sizes),
            "peaks": peaks, "width_study": width_study, "isolated_levers": isolated,
            "pilot": pilot,
            "cpu_flags": _cpu_flags(), "torch": torch.__version__,
            "platform": platform.platform(), "seconds": time.perf_counter() - start,
            "load_average_1min": {"start": load_before, "end": os.getloadavg()[0]},
            "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "commit": _commit(),
            "method": "median of adjacent baseline/candidate pairs (A/B/A/B); synthetic data"}
    sections = {"training": training, "training_bench": meta, "sampling": sampling}
    existing = read_json(out) if out.exists() else {}
    write_json(out, {**existing, **sections})
    return sections


def format_summary(sections: dict[str, Any]) -> str:
    """A plain-text table of the ratios and the achieved GFLOP/s against the peaks."""
    meta = sections["training_bench"]
    peaks = meta["peaks"]
    lines = [f"GEMM peaks ({meta['threads']} threads, n = {peaks['gemm_n']}): fp32 "
             f"{peaks['fp32_gflops']:.0f} GFLOP/s, bf16 {peaks['bf16_gflops']:.0f} GFLOP/s",
             f"{'family':18s} {'base/s':>8s} {'pkg/s':>8s} {'ratio':>6s} {'GFLOP/s':>8s} "
             f"{'%fp32':>6s}  levers (ratio vs fp32 eager)"]
    for name, row in sections["training"].items():
        levers = ", ".join(f"{k} {v['ratio_vs_fp32_eager']:.2f}" for k, v in row["levers"].items())
        lines.append(f"{name:18s} {row['baseline_samples_per_s']:8.0f} "
                     f"{row['package_samples_per_s']:8.0f} {row['ratio_vs_fp32_eager']:6.2f} "
                     f"{row['gflops']:8.1f} {100 * row['fraction_of_fp32_peak']:6.1f}  {levers}")
    for name, row in meta["isolated_levers"].items():
        if isinstance(row, dict):
            lines.append(f"isolated {name}: {row['baseline_ms']:.2f} -> {row['candidate_ms']:.2f}"
                         f" ms ({row['ratio']:.2f}x)")
    for name, row in meta["width_study"].items():
        lines.append(f"width study {name}: fp32 {row['fp32_ms_per_step']:.0f} ms/step, bf16 "
                     f"{row['bf16_ms_per_step']:.0f} ms/step ({row['bf16_speedup']:.2f}x)")
    pilot = meta["pilot"]
    for name, row in pilot.items():
        if isinstance(row, dict) and "relative_difference" in row:
            lines.append(f"pilot {name}: validation loss {pilot['validation_loss'][name]:.4f} vs "
                         f"fp32 {pilot['validation_loss']['fp32']:.4f} "
                         f"({100 * row['relative_difference']:.1f} %, tolerance "
                         f"{100 * pilot['tolerance']:.0f} %)")
    for name, row in sections["sampling"].items():
        rates = ", ".join(f"{k.replace('_samples_per_s', '')} {v:.1f}/s" for k, v in row.items()
                          if "samples_per_s" in k)
        lines.append(f"sampling {name}: {rates}")
    lines.append(f"time to gate: {GATE_NOTE}; bench took {meta['seconds']:.0f} s")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m repro.run.bench_training [--quick] [--threads N] [--out PATH]``."""
    parser = argparse.ArgumentParser(prog="repro bench --training", description=__doc__
                                     .split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds): a test")
    parser.add_argument("--threads", type=int, default=2, help="torch threads (default 2)")
    parser.add_argument("--out", default=None, help="bench.json to merge into")
    parser.add_argument("--pilot-steps", type=int, default=None,
                        help="training steps of the numerics pilot (default: the size's)")
    args = parser.parse_args(argv)
    sections = bench_training(quick=args.quick, threads=args.threads, out=args.out,
                              pilot_steps=args.pilot_steps)
    print(format_summary(sections))
    print(f"written {Path(args.out) if args.out else paths.build_root() / 'bench' / 'bench.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
