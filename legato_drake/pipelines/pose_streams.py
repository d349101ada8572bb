"""Synthetic pose-stream recordings, made by running the scripted demonstrator's diagram (the
pose-stream format itself: ``legato_drake.data.pose_stream``)."""

from __future__ import annotations

from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.data.pose_stream import PoseStream, script_to_stream
from legato_drake.diagram import build_diagram
from legato_drake.episode import initialize
from legato_drake.scenario import Scenario


def scripted_pose_stream(task: str, seed: int, embodiment: str = "abstract",
                         rate: float | None = None, X_WT: RigidTransform | None = None
                         ) -> PoseStream:
    """A synthetic recording: the scripted demonstrator's commanded poses for ``seed`` (as
    ``script_to_stream`` makes them), tagged with the seed and task so that a replay runs in
    the same scene. Simulates only the homing phase (the plan is made when it ends)."""
    scenario = Scenario(embodiment=embodiment, task=task, seed=seed)
    scenario.camera.enabled = False
    built = build_diagram(scenario)
    simulator = Simulator(built.diagram)
    initialize(built, simulator)
    simulator.AdvanceTo(conventions.HOMING_DURATION + conventions.CONTROLLER_OFFSET + 1e-4)
    script = built.controller.script(
        built.controller.GetMyContextFromRoot(simulator.get_context()))
    if script is None:
        raise RuntimeError("the scripted demonstrator made no plan")
    return script_to_stream(script.poses, script.grasps, rate=rate, X_WT=X_WT, seed=seed,
                            task=task)
