"""What a Python LeafSystem costs the closed loop by being there, before it does any work.

Simulates Panda's lid scene (seed 0) driven by the commands its closed loop sent the plant
(``bench_closed_loop.recorded_commands``), alone and beside k no-op Python systems, each a
100 Hz discrete update that writes one number (and, with "reads state", first evaluates the
plant's state input), and prints the wall time of each (median of --repeats) and the cost per
system and per call. Then times the episode's own monitor (``EpisodeRun``'s, a Python call after
every physics step that reads the success and controller-done ports) inside the closed loop
of the same scene, without cameras: its seconds, calls and share of the episode's wall time.
Usage:

    python benchmarks/bench_system_overhead.py [--embodiment panda] [--repeats 3]
        [--counts 3,6,12] [--json FILE]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time
from pathlib import Path

from bench_closed_loop import _timed, recorded_commands, replay_time, replaying_plant
from pydrake.systems.framework import Context, DiagramBuilder, DiscreteValues, LeafSystem

from legato_drake.conventions import IK_PERIOD
from legato_drake.diagram import build_diagram
from legato_drake.episode import EpisodeRun
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table


class NoOp(LeafSystem):
    """A 100 Hz discrete update that does nothing but write one number (the state's first
    entry when ``reads`` is set)."""

    def __init__(self, size: int, reads: bool):
        super().__init__()
        self._input = self.DeclareVectorInputPort("plant_state", size)
        self._state = self.DeclareDiscreteState(1)
        self._reads = reads
        self.DeclarePeriodicDiscreteUpdateEvent(IK_PERIOD, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        value = self._input.Eval(context)[0] if self._reads else 0.0
        discrete_state.set_value(self._state, [value])


def monitor_share(scenario: Scenario) -> dict:
    """The closed loop of ``scenario`` (cameras off) with its episode monitor timed: wall
    seconds of the episode and of the monitor's calls, and how many calls."""
    scenario = scenario.replace(camera=dataclasses.replace(scenario.camera, enabled=False))
    run = EpisodeRun(build_diagram(scenario, None))
    monitor, spent = run.simulator.get_monitor(), [0.0, 0]

    def timed(root):
        start = time.perf_counter()
        status = monitor(root)
        spent[0] += time.perf_counter() - start
        spent[1] += 1
        return status

    run.simulator.set_monitor(timed)
    start = time.perf_counter()
    run.advance_to(run.t_end)
    return dict(wall_s=time.perf_counter() - start, monitor_s=spent[0], calls=spent[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--embodiment", default="panda")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--counts", default="3,6,12", help="numbers of no-op systems")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    scenario = Scenario(embodiment=args.embodiment, task="lid", seed=0)
    holds, _ = recorded_commands(scenario)
    sim_time = replay_time(holds)

    def wall(count: int, reads: bool) -> float:
        times = []
        for _ in range(args.repeats):
            builder = DiagramBuilder()
            plant, _, task = replaying_plant(scenario, holds, builder)
            size = plant.num_positions() + plant.num_velocities()
            for _ in range(count):
                system = builder.AddSystem(NoOp(size, reads))
                builder.Connect(plant.get_state_output_port(), system.get_input_port())
            times.append(sim_time / _timed(builder, plant, task, scenario, sim_time)[0])
        return statistics.median(times)

    alone = wall(0, False)
    calls = round(sim_time / IK_PERIOD)
    rows, records = [[0, "-", alone, "-", "-"]], [dict(systems=0, wall_s=alone)]
    for count in (int(c) for c in args.counts.split(",")):
        for reads in (False, True):
            seconds = wall(count, reads)
            each = (seconds - alone) / count
            rows.append([count, "yes" if reads else "no", seconds, each, 1e6 * each / calls])
            records.append(dict(systems=count, reads_state=reads, wall_s=seconds,
                                per_system_s=each, per_call_us=1e6 * each / calls))
    print(f"{args.embodiment} lid, the plant replaying its closed loop for {sim_time:.1f} s "
          f"({calls} calls of each 100 Hz system)")
    print(format_table(["no-op systems", "reads state", "wall s", "s per system",
                        "us per call"], rows))
    monitor = monitor_share(scenario)
    print(f"the episode's monitor in the closed loop (cameras off): {monitor['monitor_s']:.3f} s "
          f"of {monitor['wall_s']:.2f} s ({100 * monitor['monitor_s'] / monitor['wall_s']:.1f} %), "
          f"{monitor['calls']} calls, {1e6 * monitor['monitor_s'] / monitor['calls']:.0f} us each")
    if args.json is not None:
        args.json.write_text(json.dumps(dict(embodiment=args.embodiment, sim_time=sim_time,
                                             repeats=args.repeats, rows=records,
                                             monitor=monitor), indent=1))


if __name__ == "__main__":
    main()
