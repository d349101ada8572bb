"""Closed-loop speed per embodiment: real-time factor with and without the stereo cameras.

Runs the scripted lid demonstration (seed 0, until success) and reports simulated seconds per
wall second (median of --repeats runs), beside the reference implementation's numbers on a
2-core machine (robosuite + MuJoCo, SPEC §10). Usage:

    python benchmarks/bench_closed_loop.py [--repeats 3] [--embodiments abstract,panda]
"""

from __future__ import annotations

import argparse
import statistics

from legato_drake.embodiments import EMBODIMENTS
from legato_drake.episode import run_episode
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table

# Reference real-time factors: (physics + IK + PD, + stereo cameras at 10 Hz).
REFERENCE = {"abstract": (1.11, 0.42), "panda": (1.94, 0.63), "spot": (0.90, 0.48),
             "google": (1.05, 0.55), "gr1": (0.35, 0.22)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--embodiments", default=",".join(EMBODIMENTS))
    args = parser.parse_args()
    rows = []
    for name in args.embodiments.split(","):
        for cameras in (False, True):
            scenario = Scenario(embodiment=name, seed=0)
            scenario.camera.enabled = cameras
            results = [run_episode(scenario) for _ in range(args.repeats)]
            rtf = statistics.median(r.real_time_factor for r in results)
            reference = REFERENCE.get(name, (None, None))[int(cameras)]
            rows.append([name, "yes" if cameras else "no", results[0].sim_time,
                         statistics.median(r.wall_time for r in results), rtf,
                         reference if reference else "-",
                         f"{rtf / reference:.1f}x" if reference else "-",
                         all(r.success for r in results)])
    print(format_table(["embodiment", "cameras", "sim s", "wall s", "x real time",
                        "reference x real time", "ours/reference", "success"], rows))


if __name__ == "__main__":
    main()
