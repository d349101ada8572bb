"""Policy inference time per 10 Hz step on the CPU (one torch thread, as in evaluation).

Times the ``PolicyController``'s whole update (observation, network, rollout state) for the
small state config, the small image config, the paper config, the Diffusion Policy state
configs and the image Diffusion Policy (untrained weights: the time does not depend on them),
median, p95 and max over --steps steps. A Diffusion Policy samples a chunk every
``action_horizon`` steps (DDIM, ``inference_steps``) and only reads its observation in
between, so its max is the re-plan. The bars (issue 15 and the policies issue): 20 ms per step
for the small recurrent configs, 30 ms per re-plan for the Diffusion Policy state configs, and
for the image Diffusion Policy a re-plan within a policy step (100 ms). Usage:

    python benchmarks/bench_policy.py [--steps 100] [--threads 1] [--json FILE]
        [--configs dp_reltraj_state --set obs_horizon=10 --set seq_length=25 ...]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from legato_drake import conventions
from legato_drake.data.derived import observation_sizes
from legato_drake.diagram import build_plant, object_bodies
from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import Checkpoint
from legato_drake.learning.config import LearningConfig, load_config
from legato_drake.learning.registry import build_policy, extra_stats
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table
from legato_drake.systems.episode_recorder import EpisodeRecorder
from legato_drake.systems.policy_controller import PolicyController

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
DIMS = observation_sizes(3)  # the lid scene's stove, pot and lid


def time_controller(config: LearningConfig, steps: int) -> list[float]:
    """Seconds per controller update of a policy of ``config``."""
    stats = {k: {"mean": np.zeros(d, np.float32), "std": np.ones(d, np.float32)}
             for k, d in DIMS.items()}
    stats.update(extra_stats(config, [np.zeros((40, 7))]))
    ckpt = Checkpoint(config, stats, build_policy(config, stats).eval())
    plant, _, robot, _ = build_plant(Scenario(embodiment="abstract"), DiagramBuilder())
    if config.obs_mode == "state":
        features = EpisodeRecorder(plant, robot.tcp_frame, images=False,
                                   object_bodies=object_bodies(plant, robot))
        controller = PolicyController(ckpt, features, threads=None)
        context = controller.CreateDefaultContext()
        controller.get_plant_state_input_port().FixValue(
            context, plant.GetPositionsAndVelocities(plant.CreateDefaultContext()))
        controller.get_commanded_pose_input_port().FixValue(
            context, [0.1, -0.3, 0.8, 1.0, 0.0, 0.0, 0.0])
    else:
        controller = PolicyController(ckpt, threads=None)
        context = controller.CreateDefaultContext()
        rng = np.random.default_rng(0)
        for port in controller.get_image_input_ports():
            port.FixValue(context, rng.integers(0, 256, (128, 128, 1), dtype=np.uint8))
    simulator = Simulator(controller, context)
    times = []
    for k in range(steps + 3):
        start = time.perf_counter()
        simulator.AdvanceTo(conventions.HOMING_DURATION + k * conventions.POLICY_PERIOD + 0.002)
        times.append(time.perf_counter() - start)
    return times[3:]  # the first steps warm up


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--configs", default="legato_small_state,legato_small_image,"
                                             "legato_paper,dp_velocity_state,dp_reltraj_state,"
                                             "dp_reltraj_image")
    parser.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                        help="override a field of every config timed (repeatable)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    try:  # every config and override checked before any timing
        configs = {name: load_config(CONFIGS / f"{name}.yaml", args.set)
                   for name in args.configs.split(",")}
    except ConfigError as e:
        parser.error(str(e))
    rows = []
    for name, config in configs.items():
        times = 1e3 * np.array(time_controller(config, args.steps))
        chunked = config.algo.startswith("dp_")
        worst = float(times.max())
        if not chunked:
            bar = 20.0
        else:
            bar = 1e3 * conventions.POLICY_PERIOD if config.obs_mode == "image" else 30.0
        rows.append(dict(config=name, median_ms=float(np.median(times)),
                         p95_ms=float(np.percentile(times, 95)), max_ms=worst, bar_ms=bar,
                         meets_bar=bool((worst if chunked else np.median(times)) <= bar)))
    print(format_table(["config", "median ms/step", "p95 ms/step", "max ms/step",
                        "bar ms", "meets bar"],
                       [[r["config"], r["median_ms"], r["p95_ms"], r["max_ms"], r["bar_ms"],
                         "yes" if r["meets_bar"] else "no"] for r in rows]))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(threads=args.threads, overrides=args.set,
                                             rows=rows), indent=1))


if __name__ == "__main__":
    main()
