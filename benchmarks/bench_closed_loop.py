"""Closed-loop speed per embodiment: real-time factor with and without the stereo cameras,
beside the plant alone in the same scene.

Runs the scripted lid demonstration (seed 0) and reports simulated seconds per wall second
(median of --repeats runs), beside the reference implementation's numbers on a 2-core machine
(robosuite + MuJoCo, SPEC §10). "plant alone" simulates the same scene for the same time with
the robot held at home by its joint PD and constant gravity torques, and no controller, IK,
monitor or camera: the physical cost of that scene on this machine, the floor the closed
loop's ``closed/plant`` ratio (wall time over the plant's wall time) is measured against.
"plant replaying" simulates the same scene driven by the very commands the closed loop sent
the plant (its joint and finger set points and feed-forward torques, recorded at every physics
step and played back by Drake's own ``TrajectorySource``), so it has the closed loop's motion
and contacts (the grasp, the carried object) without any of our systems: the closed loop's
wall time over it is what our controllers, IK and monitors cost, and its own over the plant
held at home is what the task's contacts cost. Its objects end where the closed loop's did
(the ``replay error`` column, mm).
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
from pydrake.systems.framework import DiagramBuilder, EventStatus
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from legato_drake.conventions import PHYSICS_DT
from legato_drake.diagram import build_diagram, build_plant, object_bodies
from legato_drake.embodiments import EMBODIMENTS
from legato_drake.episode import EpisodeRun, run_episode
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table

# Reference real-time factors: (physics + IK + PD, + stereo cameras at 10 Hz).
REFERENCE = {"abstract": (1.11, 0.42), "panda": (1.94, 0.63), "spot": (0.90, 0.48),
             "google": (1.05, 0.55), "gr1": (0.35, 0.22)}


def plant_alone_rtf(scenario: Scenario, sim_time: float) -> float:
    """Real-time factor of the scenario's plant and scene alone, held at home for
    ``sim_time`` simulated seconds from the scenario's seeded initial state."""
    builder = DiagramBuilder()
    plant, robot, task, q, tau = _held_at_home(scenario, builder)
    for value, port in ((np.concatenate([q, np.zeros(len(q))]),
                         plant.get_desired_state_input_port(robot.robot)),
                        (np.zeros(2 * plant.num_actuated_dofs(robot.gripper)),
                         plant.get_desired_state_input_port(robot.gripper)),
                        (tau, plant.get_actuation_input_port(robot.robot))):
        builder.Connect(builder.AddSystem(ConstantVectorSource(value)).get_output_port(), port)
    return _timed(builder, plant, task, scenario, sim_time)[0]


def _held_at_home(scenario: Scenario, builder: DiagramBuilder):
    """The scenario's plant in ``builder`` and its robot's home posture with the gravity
    torques that hold it there."""
    plant, _, robot, task = build_plant(scenario, builder)
    home = robot.home
    q = np.array([home.get(j.name(), 0.0) for j in robot.actuated_joints])
    context = plant.CreateDefaultContext()
    full_q = plant.GetPositions(context)
    full_q[[j.position_start() for j in robot.actuated_joints]] = q
    plant.SetPositions(context, full_q)
    tau = -plant.CalcGravityGeneralizedForces(context)[
        [j.velocity_start() for j in robot.actuated_joints]]
    return plant, robot, task, q, tau


def _timed(builder: DiagramBuilder, plant, task, scenario: Scenario, sim_time: float
           ) -> tuple[float, Simulator]:
    """Builds ``builder``'s diagram, seeds the scene as an episode does and simulates it for
    ``sim_time``; returns the real-time factor and the simulator."""
    simulator = Simulator(builder.Build())
    task.set_initial_state(plant, plant.GetMyMutableContextFromRoot(
        simulator.get_mutable_context()), np.random.default_rng(scenario.seed))
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(sim_time)
    return sim_time / (time.perf_counter() - start), simulator


def recorded_commands(scenario: Scenario) -> tuple[dict, np.ndarray]:
    """Runs the scenario's closed loop, recording at every physics step what the plant's
    command inputs read (the robot's and the gripper's PD set points, the robot's
    feed-forward torques); returns them as zero-order holds by input name, and the final
    object positions."""
    built = build_diagram(scenario)
    plant = built.plant
    ports = _command_ports(plant, built.robot)
    times, values = [], {name: [] for name in ports}
    run = EpisodeRun(built)
    episode_monitor = run.simulator.get_monitor()  # ends the episode as it ends it

    def record(root) -> EventStatus:
        context = plant.GetMyContextFromRoot(root)
        # Events of different periods meet a rounding error apart (0.01 and 5 x 0.002): the
        # plant's step reads what the later of two such calls reads.
        if times and root.get_time() - times[-1] < 1e-9:
            times.pop()
            for v in values.values():
                v.pop()
        times.append(root.get_time())
        for name, port in ports.items():
            values[name].append(port.Eval(context).copy())
        return episode_monitor(root)

    record(run.context)  # what the first step reads
    run.simulator.set_monitor(record)
    run.advance_to(run.t_end)
    # A value read at t drives the step taken at t: hold it from half a step before to half
    # a step after (no break falls on a step's time).
    half = PHYSICS_DT / 2
    breaks = np.concatenate([[times[0] - half], np.asarray(times) + half])
    holds = {name: PiecewisePolynomial.ZeroOrderHold(
        breaks, np.column_stack([*v, v[-1]])) for name, v in values.items()}
    return holds, _object_positions(plant, plant.GetMyContextFromRoot(run.context),
                                    built.robot)


def _command_ports(plant, robot) -> dict:
    """The plant's command inputs, by name."""
    return {"robot_desired": plant.get_desired_state_input_port(robot.robot),
            "gripper_desired": plant.get_desired_state_input_port(robot.gripper),
            "actuation": plant.get_actuation_input_port(robot.robot)}


def _object_positions(plant, context, robot) -> np.ndarray:
    return np.concatenate([b.EvalPoseInWorld(context).translation()
                           for b in object_bodies(plant, robot)])


def replay_time(holds: dict) -> float:
    """Simulated seconds the recorded commands ``holds`` cover."""
    return holds["actuation"].end_time() - PHYSICS_DT / 2


def replaying_plant(scenario: Scenario, holds: dict, builder: DiagramBuilder):
    """The scenario's plant in ``builder``, its command inputs driven by the recorded
    commands ``holds`` (``recorded_commands``); returns the plant, its robot and task."""
    plant, robot, task, _, _ = _held_at_home(scenario, builder)
    for name, port in _command_ports(plant, robot).items():
        builder.Connect(builder.AddSystem(TrajectorySource(holds[name])).get_output_port(),
                        port)
    return plant, robot, task


def plant_replay_rtf(scenario: Scenario, holds: dict, objects: np.ndarray
                     ) -> tuple[float, float]:
    """Real-time factor of the scenario's plant driven by the closed loop's recorded commands
    (``recorded_commands``), and how far (mm, the largest over the objects) its objects end
    from where the closed loop left them (``objects``)."""
    builder = DiagramBuilder()
    plant, robot, task = replaying_plant(scenario, holds, builder)
    sim_time = replay_time(holds)
    rtf, simulator = _timed(builder, plant, task, scenario, sim_time)
    final = _object_positions(plant, plant.GetMyContextFromRoot(simulator.get_context()),
                              robot)
    error = 1e3 * np.max(np.linalg.norm((final - objects).reshape(-1, 3), axis=1))
    return rtf, float(error)


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
        holds, objects = recorded_commands(scenario)  # once: the closed loop is deterministic
        replay = [plant_replay_rtf(scenario, holds, objects) for _ in range(args.repeats)]
        replay_rtf = statistics.median(r[0] for r in replay)
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
                         f"{plant_rtf / rtf:.2f}x", replay_rtf, f"{replay_rtf / rtf:.2f}x",
                         f"{plant_rtf / replay_rtf:.2f}x", f"{replay[0][1]:.2f}",
                         reference if reference else "-",
                         f"{rtf / reference:.1f}x" if reference else "-",
                         all(r.success for r in results)])
            records.append(dict(embodiment=name, task=args.task, cameras=cameras,
                                sim_time=results[0].sim_time, rtf=rtf, plant_rtf=plant_rtf,
                                closed_over_plant=plant_rtf / rtf, replay_rtf=replay_rtf,
                                closed_over_replay=replay_rtf / rtf,
                                replay_over_plant=plant_rtf / replay_rtf,
                                replay_error_mm=replay[0][1],
                                success=all(r.success for r in results)))
    print(format_table(["embodiment", "cameras", "sim s", "wall s", "x real time",
                        "plant alone x real time", "closed/plant",
                        "plant replaying x real time", "closed/replaying", "replaying/plant",
                        "replay error mm", "reference x real time",
                        "ours/reference", "success"], rows))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(repeats=args.repeats, rows=records), indent=1))


if __name__ == "__main__":
    main()
