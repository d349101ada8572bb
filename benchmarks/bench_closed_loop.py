"""Closed-loop speed per embodiment: real-time factor with and without the stereo cameras,
beside the plant alone in the same scene.

Runs the scripted lid demonstration (seed 0) and reports simulated seconds per wall second
(median of --repeats runs), beside the reference implementation's numbers on a 2-core machine
(robosuite + MuJoCo, SPEC §10). "plant alone" simulates the same scene for the same time with
the robot held at home by its joint PD and constant gravity torques, and no controller, IK,
monitor or camera: the physical cost of that scene on this machine, the floor the closed
loop's ``closed/plant`` ratio (wall time over the plant's wall time) is measured against.
Usage:

    python benchmarks/bench_closed_loop.py [--repeats 3] [--embodiments abstract,panda]
        [--task lid] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from legato_drake.diagram import build_plant
from legato_drake.embodiments import EMBODIMENTS
from legato_drake.episode import run_episode
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table

# Reference real-time factors: (physics + IK + PD, + stereo cameras at 10 Hz).
REFERENCE = {"abstract": (1.11, 0.42), "panda": (1.94, 0.63), "spot": (0.90, 0.48),
             "google": (1.05, 0.55), "gr1": (0.35, 0.22)}


def plant_alone_rtf(scenario: Scenario, sim_time: float) -> float:
    """Real-time factor of the scenario's plant and scene alone, held at home for
    ``sim_time`` simulated seconds from the scenario's seeded initial state."""
    builder = DiagramBuilder()
    plant, _, robot, task = build_plant(scenario, builder)
    home = robot.home
    q = np.array([home.get(j.name(), 0.0) for j in robot.actuated_joints])
    held = builder.AddSystem(ConstantVectorSource(np.concatenate([q, np.zeros(len(q))])))
    builder.Connect(held.get_output_port(), plant.get_desired_state_input_port(robot.robot))
    fingers = builder.AddSystem(ConstantVectorSource(
        np.zeros(2 * plant.num_actuated_dofs(robot.gripper))))
    builder.Connect(fingers.get_output_port(),
                    plant.get_desired_state_input_port(robot.gripper))
    context = plant.CreateDefaultContext()
    full_q = plant.GetPositions(context)
    full_q[[j.position_start() for j in robot.actuated_joints]] = q
    plant.SetPositions(context, full_q)
    tau = -plant.CalcGravityGeneralizedForces(context)[
        [j.velocity_start() for j in robot.actuated_joints]]
    gravity = builder.AddSystem(ConstantVectorSource(tau))
    builder.Connect(gravity.get_output_port(), plant.get_actuation_input_port(robot.robot))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    task.set_initial_state(plant, plant.GetMyMutableContextFromRoot(
        simulator.get_mutable_context()), np.random.default_rng(scenario.seed))
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(sim_time)
    return sim_time / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--embodiments", default=",".join(EMBODIMENTS))
    parser.add_argument("--task", default="lid")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    rows, records = [], []
    for name in args.embodiments.split(","):
        scenario = Scenario(embodiment=name, task=args.task, seed=0)
        plant_rtf = None
        for cameras in (False, True):
            scenario.camera.enabled = cameras
            results = [run_episode(scenario) for _ in range(args.repeats)]
            rtf = statistics.median(r.real_time_factor for r in results)
            if plant_rtf is None:
                plant_rtf = statistics.median(plant_alone_rtf(scenario, results[0].sim_time)
                                              for _ in range(args.repeats))
            reference = REFERENCE.get(name, (None, None))[int(cameras)]
            rows.append([name, "yes" if cameras else "no", results[0].sim_time,
                         statistics.median(r.wall_time for r in results), rtf, plant_rtf,
                         f"{plant_rtf / rtf:.2f}x", reference if reference else "-",
                         f"{rtf / reference:.1f}x" if reference else "-",
                         all(r.success for r in results)])
            records.append(dict(embodiment=name, task=args.task, cameras=cameras,
                                sim_time=results[0].sim_time, rtf=rtf, plant_rtf=plant_rtf,
                                closed_over_plant=plant_rtf / rtf,
                                success=all(r.success for r in results)))
    print(format_table(["embodiment", "cameras", "sim s", "wall s", "x real time",
                        "plant alone x real time", "closed/plant", "reference x real time",
                        "ours/reference", "success"], rows))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(repeats=args.repeats, rows=records), indent=1))


if __name__ == "__main__":
    main()
