"""IK solve time per embodiment: our WholeBodyIK QP beside Drake's DifferentialInverseKinematics.

Both solve the same problem at the same states: the joint velocities that move the gripper TCP
toward a target pose (a sequence of targets 2-15 cm and up to 0.4 rad from home, tracked by
our IK's own integration), from the same joint positions. Drake's solver prints OSQP chatter on
stdout at many solves; it is silenced at the file-descriptor level here. Usage:

    python benchmarks/bench_ik.py [--steps 2000] [--json FILE]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import time
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import (
    DifferentialInverseKinematicsParameters,
    DoDifferentialInverseKinematics,
)
from pydrake.systems.framework import DiagramBuilder

from legato_drake.diagram import build_plant
from legato_drake.embodiments import EMBODIMENTS
from legato_drake.poses import spatial_error
from legato_drake.scenario import Scenario
from legato_drake.summary import format_table
from legato_drake.systems.whole_body_ik import WholeBodyIK

# The reference implementation's eSNS IK (numpy), median per solve (SPEC §10).
REFERENCE_MS = {"panda": 1.34, "spot": 3.73, "google": 3.68, "gr1": 3.50}


@contextlib.contextmanager
def silenced_stdout():
    """Redirects file descriptor 1 (C++ printf included) to /dev/null."""
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


def targets(X0: RigidTransform, n: int, rng: np.random.Generator) -> list[RigidTransform]:
    """n waypoint targets around X0, each held for 50 IK steps."""
    out = []
    for _ in range(n // 50 + 1):
        offset = rng.uniform(-0.15, 0.15, 3)
        R = RotationMatrix.MakeZRotation(rng.uniform(-0.4, 0.4)) @ \
            RotationMatrix.MakeYRotation(rng.uniform(-0.3, 0.3))
        out += [RigidTransform(X0.rotation() @ R, X0.translation() + offset)] * 50
    return out[:n]


def bench(name: str, steps: int) -> list:
    plant, _, robot, _ = build_plant(Scenario(embodiment=name), DiagramBuilder())
    ik = WholeBodyIK(plant, robot)
    rng = np.random.default_rng(0)
    q, v = robot.home_positions.copy(), np.zeros(ik.num_joints)
    active = None  # the warm start the system keeps in its state
    goals = targets(ik.tcp_pose(q), steps, rng)

    context = plant.CreateDefaultContext()
    params = DifferentialInverseKinematicsParameters(plant.num_positions(),
                                                     plant.num_velocities())
    params.set_time_step(ik._dt)
    params.set_joint_velocity_limits((-np.full(plant.num_velocities(), 2.5),
                                      np.full(plant.num_velocities(), 2.5)))
    ours, theirs, qp_share = [], [], 0
    for X_des in goals:
        start = time.perf_counter()
        step = ik.solve(q, v, X_des, np.zeros(6), active)
        ours.append(time.perf_counter() - start)
        qp_share += step.status == "qp"

        V = robot.embodiment.ik.tracking_gain * spatial_error(ik.tcp_pose(q), X_des)
        full_q = plant.GetPositions(context)
        full_q[[j.position_start() for j in robot.controlled_joints]] = q
        plant.SetPositions(context, full_q)
        with silenced_stdout():
            start = time.perf_counter()
            DoDifferentialInverseKinematics(plant, context, V, robot.tcp_frame, params)
            theirs.append(time.perf_counter() - start)
        v, active = step.v, step.active if step.active is not None else active
        q = np.clip(q + v * ik._dt, ik._q_min, ik._q_max)
    ours_ms, theirs_ms = 1e3 * np.array(ours), 1e3 * np.array(theirs)
    reference = REFERENCE_MS.get(name)
    return [name, ik.num_joints, float(np.median(ours_ms)), float(np.percentile(ours_ms, 95)),
            f"{100 * qp_share / steps:.0f}%", float(np.median(theirs_ms)),
            float(np.percentile(theirs_ms, 95)),
            f"{np.median(theirs_ms) / np.median(ours_ms):.2f}x",
            f"{reference / np.median(ours_ms):.1f}x" if reference else "-"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the rows there")
    args = parser.parse_args()
    rows = [bench(name, args.steps) for name in EMBODIMENTS]
    headers = ["embodiment", "dof", "ours median ms", "ours p95 ms", "bounded QP",
               "drake diffik median ms", "drake p95 ms", "drake/ours", "reference/ours"]
    print(format_table(headers, rows))
    if args.json is not None:
        args.json.write_text(json.dumps(dict(steps=args.steps, rows=[
            dict(embodiment=r[0], dof=r[1], median_ms=r[2], p95_ms=r[3], bounded_qp=r[4],
                 drake_median_ms=r[5], drake_p95_ms=r[6]) for r in rows]), indent=1))


if __name__ == "__main__":
    main()
