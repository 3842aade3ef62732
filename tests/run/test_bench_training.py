"""The training bench in its quick mode: sections, keys, merging, and its helpers."""

from __future__ import annotations

import json
import math

import pytest
import torch

from repro.run import bench_training
from repro.run.bench_training import FULL, QUICK, step_gflop
from repro.run.bench_training import bench_training as run_bench

FAMILIES = {"gmd_trajectory", "gmd_motion", "vae", "latent_denoiser", "evaluator"}


@pytest.fixture(scope="module")
def quick_bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "bench.json"
    out.write_text(json.dumps({"machine": {"cpus": 2}, "rows": {"unit_tests": {"seconds": 1}}}))
    return out, run_bench(quick=True, threads=1, out=out)


def test_quick_bench_writes_every_family_and_keeps_other_keys(quick_bench):
    out, sections = quick_bench
    written = json.loads(out.read_text())
    assert written["rows"] == {"unit_tests": {"seconds": 1}}          # merged, not dropped
    assert written["machine"] == {"cpus": 2}
    assert set(written["training"]) == FAMILIES
    for name, row in written["training"].items():
        assert row["ratio_vs_fp32_eager"] > 0 and math.isfinite(row["ratio_vs_fp32_eager"])
        assert row["gflops"] > 0 and row["gflop_per_step"] > 0, name
        assert row["seconds_to_gate"] is None and row["gate"] == bench_training.GATE_NOTE
        assert 0 < row["fraction_of_fp32_peak"] and 0 < row["fraction_of_bf16_peak"]
    assert set(written["training"]["gmd_motion"]["levers"]) == {
        "fast_mish", "fast_mish+fused_adamw", "bf16_autocast"}
    meta = written["training_bench"]
    assert meta["mode"] == "quick" and meta["threads"] == 1
    assert set(meta["width_study"]) == {"base16", f"width{QUICK.wide_width}", "notebook_motion"}
    assert "0.5, 0.25]" in meta["width_study"]["notebook_motion"]["model"]
    assert {"fp32", "bf16_autocast"} <= set(meta["pilot"]["validation_loss"])
    for name in ("fast_mish_forward_backward", "fast_mish_forward", "update_foreach_vs_loop",
                 "update_fused_vs_loop"):
        assert meta["isolated_levers"][name]["ratio"] > 0
    assert set(written["sampling"]) == {"gmd_trajectory", "gmd_motion", "latent_denoiser"}
    for row in written["sampling"].values():
        assert row["ddpm_batching_gain"] > 0 and row["ddim_batching_gain"] > 0
    assert sections["training"] == written["training"]


def test_summary_names_every_family_and_the_gate_note(quick_bench):
    _, sections = quick_bench
    text = bench_training.format_summary(sections)
    for name in FAMILIES:
        assert name in text
    assert bench_training.GATE_NOTE in text and "GEMM peaks" in text


def test_the_full_bench_is_bigger_than_the_quick_one_and_uses_wide_models():
    assert FULL.steps > QUICK.steps and FULL.repeats >= 3 and FULL.gemm_n >= 1024
    assert FULL.wide_width >= 263


def test_step_gflop_counts_a_linear_layer_forward_and_backward():
    layer = torch.nn.Linear(64, 32)
    x = torch.randn(16, 64, requires_grad=True)
    # forward 2·16·64·32, backward (input and weight gradients) twice that
    assert step_gflop(lambda: layer(x).sum().backward()) == pytest.approx(
        3 * 2 * 16 * 64 * 32 / 1e9)


def test_paired_ratios_is_the_median_of_adjacent_pairs():
    times = iter([1.0, 1.0, 2.0, 1.0, 4.0, 1.0, 3.0, 1.0])     # warm-up pair, then 3 pairs
    pair = bench_training.paired_ratios(lambda steps: next(times), lambda steps: next(times),
                                        steps=1, repeats=3)
    assert pair["ratios"] == [2.0, 4.0, 3.0] and pair["ratio"] == 3.0


def test_main_prints_the_summary(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(bench_training, "bench_training",
                        lambda **kwargs: {"called": kwargs})
    monkeypatch.setattr(bench_training, "format_summary", lambda sections: "SUMMARY")
    assert bench_training.main(["--quick", "--threads", "1", "--out",
                                str(tmp_path / "b.json")]) == 0
    assert "SUMMARY" in capsys.readouterr().out
