"""What this machine's CPU can do for training: its model name and whether it computes
bfloat16 natively, read from ``/proc/cpuinfo`` (Linux; elsewhere unknown).

Why it matters: ``encoder_precision: bfloat16`` halves the image trunk's time on a CPU with
AVX512_BF16 or AMX (an AMD Zen 4, an Intel Sapphire Rapids), and makes it about 8x *slower*
than float32 where PyTorch must emulate it (an AMD Zen 3: 1877 against 257 ms per training
step of ``configs/legato_small_image.yaml``, ``benchmarks/bench_training_step.py``).
"""

from __future__ import annotations

import contextlib
import functools
import platform
from pathlib import Path

CPUINFO = Path("/proc/cpuinfo")
BFLOAT16_FLAGS = frozenset({"avx512_bf16", "amx_bf16", "bf16"})
"""cpuinfo flags of native bfloat16 arithmetic: x86's AVX-512 BF16 and AMX, Arm's BF16."""


@functools.cache
def _cpuinfo() -> str:
    """This machine's cpuinfo text, read once per process ("" where there is none)."""
    with contextlib.suppress(OSError):
        return CPUINFO.read_text()
    return ""


def cpu_model() -> str:
    """The CPU's model name (``platform.processor()`` where cpuinfo has none)."""
    for line in _cpuinfo().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def native_bfloat16(cpuinfo: str | None = None) -> bool | None:
    """Whether the CPU computes bfloat16 natively; None where cpuinfo lists no flags (not
    Linux). ``cpuinfo``: that file's text (default: this machine's)."""
    text = _cpuinfo() if cpuinfo is None else cpuinfo
    flags: set[str] = set()
    for line in text.splitlines():
        name, _, value = line.partition(":")
        if name.strip() in ("flags", "Features"):  # x86, Arm
            flags.update(value.split())
    return bool(flags & BFLOAT16_FLAGS) if flags else None
