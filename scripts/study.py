"""The learned-policy study of the README in one command: collect -> train -> select ->
evaluate -> table, per task, resumable at every stage.

    python scripts/study.py --task lid --methods legato,legato_se3,bc_rnn --train-seeds 0,1,2 \\
        --trials 50 --workers 2 --out study

Stages (each skipped when its output is complete, so a rerun resumes):

1. ``OUT/<task>/data.hdf5``: ``--episodes`` scripted Abstract demonstrations, state only, with
   the DART-style expert noise (``--noise-mm``, ``--noise-deg``) and the release, hold and
   retreat recorded;
2. ``OUT/<task>/runs/<method>_seed<s>``: one training run per method and training seed, with
   snapshots every ``--snapshot-every`` steps;
3. ``selected.pt`` per run: the snapshot with the most successes on ``--select-trials``
   validation scene seeds from 5000 (disjoint from training and evaluation seeds);
4. ``OUT/<task>/results/<method>_seed<s>.json``: ``--trials`` trials per robot, scene seeds
   from 10000;
5. the table (``scripts/eval_table.py``) on stdout and ``OUT/<task>/table.md``, and the plot
   ``OUT/<task>/success_rates.png``.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.files import atomic_write_text
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.config import load_config
from legato_drake.learning.train import train
from legato_drake.pipelines.collect import collect
from legato_drake.pipelines.evaluate import combine, evaluate, plot_success
from legato_drake.pipelines.selection import select_checkpoint
from legato_drake.scenario import ExpertNoiseConfig

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
METHODS = {
    "legato": ("legato_small_state.yaml", []),
    "legato_se3": ("legato_small_state.yaml",
                   ["invariant_weight=0", "name=legato_small_state_se3"]),
    "bc_rnn": ("bc_rnn_small_state.yaml", []),
}
"""Method name -> (learning config, overrides)."""

log = logging.getLogger("study")


def _train(method: str, seed: int, data: Path, run: Path, snapshot_every: int) -> None:
    name, overrides = METHODS[method]
    config = load_config(CONFIGS / name, [*overrides, f"seed={seed}",
                                          f"snapshot_every={snapshot_every}"])
    last = run / "last.pt"
    if last.is_file() and load_checkpoint(last).step >= config.steps:
        return
    train(config, data, run, resume=last.is_file())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="lid", choices=["lid", "cup", "ladle"])
    parser.add_argument("--methods", default="legato,legato_se3",
                        help=f"comma-separated, of {', '.join(METHODS)}")
    parser.add_argument("--train-seeds", default="0,1,2", help="comma-separated")
    parser.add_argument("--embodiments", default="all", help="comma-separated or 'all'")
    parser.add_argument("--episodes", type=int, default=150)
    parser.add_argument("--noise-mm", type=float, default=5.0)
    parser.add_argument("--noise-deg", type=float, default=2.0)
    parser.add_argument("--snapshot-every", type=int, default=5000)
    parser.add_argument("--select-trials", type=int, default=20,
                        help="validation seeds for checkpoint selection (0: use last.pt)")
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("study"))
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    methods = [m.strip() for m in args.methods.split(",")]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        parser.error(f"--methods: unknown {', '.join(unknown)}; valid: {', '.join(METHODS)}")
    seeds = [int(s) for s in args.train_seeds.split(",")]
    embodiments = (list(EMBODIMENTS) if args.embodiments == "all"
                   else args.embodiments.split(","))
    root = args.out / args.task
    data = root / "data.hdf5"
    collect(args.task, "abstract", args.episodes, data, workers=args.workers, camera=False,
            expert_noise=ExpertNoiseConfig(args.noise_mm / 1000, args.noise_deg))
    results = []
    for method in methods:
        for seed in seeds:
            run = root / "runs" / f"{method}_seed{seed}"
            _train(method, seed, data, run, args.snapshot_every)
            checkpoint = run / "last.pt"
            if args.select_trials:
                if not (run / "selected.pt").is_file():
                    select_checkpoint(run, args.task, trials=args.select_trials,
                                      workers=args.workers)
                checkpoint = run / "selected.pt"
            evaluate(checkpoint, embodiments, [args.task], args.trials, root / "results",
                     workers=args.workers, method=f"{method}_seed{seed}")
            results.append(root / "results" / f"{method}_seed{seed}.json")
    from eval_table import table  # scripts/ is on sys.path when run as a script

    lines = table(results, args.task)
    atomic_write_text(root / "table.md", "\n".join(lines) + "\n")
    plot_success(combine(results), root / "success_rates.png", title=f"task: {args.task}")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
