"""Time phi and L_invar on CPU: batch of 16 windows x 20 steps (float32 torch, plus numpy).

Run ``python benchmarks/bench_invariants.py [--threads N] [--json FILE]``; prints one table
(median and p95 microseconds per call over a few hundred calls after warm-up). The default
of 2 threads is the project's 2-core machine; on a machine whose other core is busy, 1 thread
avoids the long stalls of a descheduled intra-op worker.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a plain checkout too
from legato_drake.invariants import invariant_loss, invariants_from_deltas  # noqa: E402

THREADS = 2  # the project's reference machine has 2 cores
BATCH, STEPS = 16, 20
WARMUP, CALLS = 20, 300


def time_calls(fn: Callable[[], object]) -> tuple[float, float]:
    """Median and p95 wall time of ``fn`` in microseconds."""
    for _ in range(WARMUP):
        fn()
    times = []
    for _ in range(CALLS):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    micros = np.array(times) * 1e6
    return float(np.median(micros)), float(np.percentile(micros, 95))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--threads", type=int, default=THREADS, help="torch.set_num_threads")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    threads = args.threads
    torch.set_num_threads(threads)
    rng = np.random.default_rng(0)
    deltas_np = (rng.normal(size=(BATCH, STEPS, 6)) * 0.02).astype(np.float32)
    deltas = torch.from_numpy(deltas_np)
    history, demo = deltas[:, :-1], deltas[:, -1]
    predicted = (demo + 0.01 * torch.randn(BATCH, 6)).requires_grad_()
    chunk_history, chunk_demo = deltas[:, :4], deltas[:, 4:]  # P + 1 = 16 actions
    chunk = (chunk_demo + 0.01 * torch.randn_like(chunk_demo)).requires_grad_()

    def phi_torch() -> None:
        with torch.no_grad():
            invariants_from_deltas(deltas)

    def loss_forward() -> None:
        with torch.no_grad():
            invariant_loss(history, predicted, demo)

    def loss_forward_backward() -> None:
        invariant_loss(history, predicted, demo).backward()
        predicted.grad = None

    def chunk_forward_backward() -> None:
        invariant_loss(chunk_history, chunk, chunk_demo).backward()
        chunk.grad = None

    rows = [
        ("phi, torch float32, forward", phi_torch),
        ("phi, numpy float32", lambda: invariants_from_deltas(deltas_np)),
        ("L_invar one action, forward", loss_forward),
        ("L_invar one action, forward + backward", loss_forward_backward),
        ("L_invar chunk P+1=16, forward + backward", chunk_forward_backward),
    ]
    print(f"batch {BATCH} x {STEPS} steps, CPU, torch {torch.__version__}, "
          f"torch.set_num_threads({threads}), {CALLS} calls after {WARMUP} warm-up")
    print(f"| {'what':<42} | {'median us':>9} | {'p95 us':>8} |")
    print(f"| {'-' * 42} | {'-' * 9}:| {'-' * 7}:|")
    records = []
    for name, fn in rows:
        median, p95 = time_calls(fn)
        print(f"| {name:<42} | {median:>9.0f} | {p95:>8.0f} |")
        records.append(dict(what=name, median_us=median, p95_us=p95))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(threads=threads, batch=BATCH, steps=STEPS,
                                             rows=records), indent=1))


if __name__ == "__main__":
    main()
