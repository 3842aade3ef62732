"""What machine a timing was measured on: the CPU as a reader can place it among the 2-core
machines the budgets are written for (an Intel Xeon with or without AMX-BF16, an AMD EPYC)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["cpu_label"]


def cpu_label(cpuinfo: str | None = None) -> str:
    """"<model name>, <n> cores" and, for an Intel, whether it has AMX-BF16, AVX512-BF16 only
    or neither, from ``/proc/cpuinfo`` (or the text given); "unknown CPU" where it cannot be
    read. Timings differ about twofold across these CPUs, so every measured time carries its
    label."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
        except OSError:
            return "unknown CPU"
    fields: dict[str, str] = {}
    cores = 0
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        cores += key == "processor"
        fields.setdefault(key, value.strip())
    model = " ".join(fields.get("model name", "unknown CPU").replace("(R)", "").split())
    flags = set(fields.get("flags", "").split())
    if "AMD" in model:
        return f"{model}, {cores} cores"
    bf16 = ("AMX-BF16" if "amx_bf16" in flags
            else "AVX512-BF16, no AMX" if "avx512_bf16" in flags else "no AMX, no BF16")
    return f"{model}, {cores} cores, {bf16}"
