"""``build_diagram(scenario)``: the one place that wires a LEGATO episode together.

::

    StereoCamera (10 Hz) -> controller (10 Hz) -> action = [pose delta, grasp]
                                                    |                 |
                         GripperTargetIntegrator <--+                 +--> GripperActuation
                              | target pose + velocity                          |
                         WholeBodyIK (100 Hz)                                   |
                              | joint targets                   finger targets  |
                         MultibodyPlant joint PD (500 Hz) + GravityCompensation <+
                              |
                         SuccessMonitor, TrackingMonitor, MeshcatVisualizer,
                         EpisodeRecorder (with ``record=True``)

The controller sees the gripper only; the embodiment is known to the IK, the PD and the
gravity compensation alone.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pydrake.geometry import (
    Meshcat,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Role,
    SceneGraph,
)
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import Demultiplexer

from legato_drake import conventions
from legato_drake.embodiments import add_embodiment, resolve_embodiment
from legato_drake.models import add_package
from legato_drake.robot_types import RobotHandles
from legato_drake.scenario import Scenario
from legato_drake.systems.episode_recorder import EpisodeRecorder
from legato_drake.systems.external_controller import ExternalController
from legato_drake.systems.fisheye import FisheyeLens
from legato_drake.systems.gravity_compensation import GravityCompensation
from legato_drake.systems.gripper_actuation import GripperActuation
from legato_drake.systems.joint_target_mux import JointTargetMux
from legato_drake.systems.pose_replay import PoseStreamReplay
from legato_drake.systems.render_mirror import add_render_scene
from legato_drake.systems.scripted_demonstrator import (
    ExpertNoise,
    Script,
    ScriptedDemonstrator,
)
from legato_drake.systems.spot_legs import add_leg_follower
from legato_drake.systems.stereo_camera import RENDERER_NAME, StereoCamera, StereoRig
from legato_drake.systems.success_monitor import SuccessMonitor
from legato_drake.systems.target_integrator import GripperTargetIntegrator
from legato_drake.systems.tracking_monitor import TrackingMonitor
from legato_drake.systems.whole_body_ik import WholeBodyIK
from legato_drake.tasks import Task, make_task

if TYPE_CHECKING:  # torch is imported only when a policy is used
    from legato_drake.learning.checkpoint import Checkpoint
    from legato_drake.systems.policy_controller import PolicyController

log = logging.getLogger(__name__)


@dataclass
class LegatoDiagram:
    """A built episode diagram and handles to its parts."""

    scenario: Scenario
    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    robot: RobotHandles
    task: Task
    controller: ScriptedDemonstrator | PoseStreamReplay | PolicyController | ExternalController
    integrator: GripperTargetIntegrator
    ik: WholeBodyIK
    gripper: GripperActuation
    success: SuccessMonitor
    tracking: TrackingMonitor
    camera: StereoCamera | None
    visualizer: MeshcatVisualizer | None
    meshcat: Meshcat | None
    X_home: RigidTransform
    """TCP pose at the robot's home posture (where homing starts)."""
    recorder: EpisodeRecorder | None = None
    """The dataset recorder (only with ``build_diagram(..., record=True)``)."""


def build_plant(scenario: Scenario, builder: DiagramBuilder
                ) -> tuple[MultibodyPlant, SceneGraph, RobotHandles, Task]:
    """Adds the finalized plant (robot, gripper, task scene) to ``builder``."""
    config = MultibodyPlantConfig(time_step=conventions.PHYSICS_DT,
                                  discrete_contact_approximation="sap")
    plant, scene_graph = AddMultibodyPlant(config, builder)
    parser = add_package(Parser(plant))
    robot = add_embodiment(plant, parser, resolve_embodiment(scenario.embodiment,
                                                             scenario.embodiment_file))
    task = make_task(scenario.task)
    task.add_to_plant(plant, parser)
    plant.Finalize()
    return plant, scene_graph, robot, task


def stereo_rig(plant: MultibodyPlant, robot: RobotHandles, scenario: Scenario) -> StereoRig:
    """The gripper's camera rig, read from the gripper model's optical frames."""
    base = plant.GetBodyByName(conventions.GRIPPER_BASE_BODY, robot.gripper)
    poses = [plant.GetFrameByName(name, robot.gripper).GetFixedPoseInBodyFrame()
             for name in ("left_camera_optical", "right_camera_optical")]
    camera = scenario.camera
    lens = FisheyeLens(camera.width, camera.height, camera.fisheye_fov_deg) \
        if camera.model == "fisheye" else None
    return StereoRig(plant.GetBodyFrameIdOrThrow(base.index()), poses[0], poses[1],
                     width=camera.width, height=camera.height,
                     fov_y=float(np.radians(camera.fov_y_deg)), lens=lens)


def object_bodies(plant: MultibodyPlant, robot: RobotHandles) -> list:
    """The task's free bodies (not the robot's or the gripper's), in body-index order: the
    bodies whose poses make up the ``object`` observation."""
    free = [plant.get_body(i) for i in sorted(plant.GetFloatingBaseBodies())]
    return [b for b in free if b.model_instance() not in (robot.robot, robot.gripper)]


def _policy_camera(scenario: Scenario, ckpt: Checkpoint) -> Scenario:
    """``scenario`` with the camera an image policy was trained on (``Checkpoint.camera``:
    its model, field of view and size); a policy can only read the images it learned from."""
    if ckpt.config.obs_mode != "image" or not ckpt.camera:
        return scenario
    changed = {k: v for k, v in ckpt.camera.items() if getattr(scenario.camera, k) != v}
    if not changed:
        return scenario
    log.info("camera: %s, as the images of checkpoint %s were recorded",
             ", ".join(f"{k}={v}" for k, v in changed.items()), scenario.checkpoint)
    return scenario.replace(camera=dataclasses.replace(scenario.camera, **changed))


def _policy_controller(scenario: Scenario, plant: MultibodyPlant, robot: RobotHandles,
                       ckpt: Checkpoint) -> PolicyController:
    """The ``PolicyController`` of ``controller: policy`` for the loaded checkpoint."""
    from legato_drake.errors import ConfigError
    from legato_drake.systems.policy_controller import PolicyController

    if ckpt.config.obs_mode == "image":
        if not scenario.camera.enabled:
            raise ConfigError(f"camera.enabled must be true: checkpoint {scenario.checkpoint} "
                              "is an image policy (obs_mode: image)")
        return PolicyController(ckpt, scene_seed=scenario.seed)
    features = EpisodeRecorder(plant, robot.tcp_frame, images=False,
                               object_bodies=object_bodies(plant, robot))
    return PolicyController(ckpt, features, scene_seed=scenario.seed)


def build_diagram(scenario: Scenario, meshcat: Meshcat | None = None,
                  script: Script | None = None, record: bool = False) -> LegatoDiagram:
    """Builds the closed-loop diagram of ``scenario``; with ``meshcat``, adds a visualizer.
    With ``script``, the demonstrator plays that script instead of planning its own (e.g. a
    demonstration recorded on another embodiment, replayed open-loop). With ``record``, adds
    an ``EpisodeRecorder`` (one dataset sample per policy step; a perturbed expert's
    samples hold its corrective ``label``). ``controller: replay`` plays
    the scenario's ``pose_stream`` instead of the scripted demonstrator."""
    scenario.validate()
    ckpt = None
    if scenario.controller == "policy":
        from legato_drake.learning.checkpoint import load_checkpoint  # torch only here

        ckpt = load_checkpoint(scenario.checkpoint)
        scenario = _policy_camera(scenario, ckpt)
    builder = DiagramBuilder()
    plant, scene_graph, robot, task = build_plant(scenario, builder)
    X_home = robot.tcp_frame.CalcPoseInWorld(plant.CreateDefaultContext())
    state = plant.get_state_output_port()

    if scenario.controller == "replay":
        from legato_drake.data.pose_stream import load_pose_stream

        controller = builder.AddNamedSystem(
            "pose_stream_replay", PoseStreamReplay(load_pose_stream(scenario.pose_stream)))
    elif scenario.controller == "policy":
        controller = builder.AddNamedSystem(
            "policy_controller", _policy_controller(scenario, plant, robot, ckpt))
        if controller.obs_mode == "state":
            builder.Connect(state, controller.get_plant_state_input_port())
    elif scenario.controller == "external":
        controller = builder.AddNamedSystem("external_controller", ExternalController())
    else:
        noise = scenario.expert_noise
        controller = builder.AddNamedSystem(
            "scripted_demonstrator", ScriptedDemonstrator(
                plant, task, scenario.seed, script,
                noise=ExpertNoise(noise.position_std, np.radians(noise.rotation_std_deg),
                                  noise.correlation, noise.full_speed)))
        builder.Connect(state, controller.get_plant_state_input_port())
    split = builder.AddNamedSystem("action_split", Demultiplexer([6, 1]))
    builder.Connect(controller.GetOutputPort("action"), split.get_input_port())

    lead = scenario.max_target_lead if scenario.controller == "policy" else 0.0
    integrator = builder.AddNamedSystem("target_integrator", GripperTargetIntegrator(
        X_home, max_lead=lead, plant=plant, tcp=robot.tcp_frame))
    builder.Connect(split.get_output_port(0), integrator.get_delta_input_port())
    if lead > 0:
        builder.Connect(state, integrator.get_plant_state_input_port())
    gripper = builder.AddNamedSystem("gripper_actuation", GripperActuation())
    builder.Connect(split.get_output_port(1), gripper.get_grasp_input_port())
    if scenario.controller == "policy" and controller.obs_mode == "state":
        builder.Connect(integrator.GetOutputPort("X_WG_commanded"),
                        controller.get_commanded_pose_input_port())
    builder.Connect(gripper.GetOutputPort("desired_state"),
                    plant.get_desired_state_input_port(robot.gripper))

    ik = builder.AddNamedSystem("whole_body_ik", WholeBodyIK(plant, robot))
    builder.Connect(integrator.GetOutputPort("X_WG_target"),
                    ik.get_desired_pose_input_port())
    builder.Connect(integrator.GetOutputPort("V_WG_target"),
                    ik.get_desired_velocity_input_port())
    builder.Connect(state, ik.get_plant_state_input_port())
    desired = ik.GetOutputPort("desired_state")
    if robot.embodiment.leg_follower is not None:  # e.g. Spot's legs follow the body
        joints, followers = add_leg_follower(builder, plant, robot, desired)
        mux = builder.AddNamedSystem("joint_target_mux", JointTargetMux(
            robot.actuated_joints, [robot.controlled_joints, joints]))
        builder.Connect(desired, mux.get_input_port(0))
        builder.Connect(followers, mux.get_input_port(1))
        desired = mux.get_output_port()
    builder.Connect(desired, plant.get_desired_state_input_port(robot.robot))
    gravity = builder.AddNamedSystem("gravity_compensation",
                                     GravityCompensation(plant, robot.actuated_joints))
    builder.Connect(desired, gravity.get_desired_state_input_port())
    builder.Connect(gravity.GetOutputPort("actuation"),
                    plant.get_actuation_input_port(robot.robot))

    success = builder.AddNamedSystem("success_monitor", SuccessMonitor(plant, task))
    builder.Connect(state, success.get_plant_state_input_port())
    tracking = builder.AddNamedSystem("tracking_monitor", TrackingMonitor(plant, robot))
    builder.Connect(integrator.GetOutputPort("X_WG_target"),
                    tracking.GetInputPort("X_WG_target"))
    builder.Connect(state, tracking.GetInputPort("plant_state"))

    camera = None
    if scenario.camera.enabled:
        render_scene_graph, mirror = add_render_scene(builder, plant, scene_graph,
                                                      RENDERER_NAME)
        rig = stereo_rig(plant, robot, scenario)
        rig = dataclasses.replace(rig, parent_frame=mirror.mirror_frame(rig.parent_frame))
        camera = builder.AddNamedSystem("stereo_camera", StereoCamera(rig))
        builder.Connect(render_scene_graph.get_query_output_port(),
                        camera.get_geometry_query_input_port())
        if scenario.controller == "policy":
            for port in controller.get_image_input_ports():
                builder.Connect(camera.GetOutputPort(port.get_name()), port)

    recorder = None
    if record:
        recorder = builder.AddNamedSystem("episode_recorder", EpisodeRecorder(
            plant, robot.tcp_frame, images=camera is not None,
            object_bodies=object_bodies(plant, robot)))
        # The dataset's action is the controller's label where it has one (a perturbed
        # expert's correction), else what it executes.
        label = "label" if controller.HasOutputPort("label") else "action"
        builder.Connect(controller.GetOutputPort(label), recorder.get_action_input_port())
        builder.Connect(integrator.GetOutputPort("X_WG_commanded"),
                        recorder.get_commanded_pose_input_port())
        builder.Connect(state, recorder.get_plant_state_input_port())
        for port in recorder.get_image_input_ports():
            builder.Connect(camera.GetOutputPort(port.get_name()), port)

    visualizer = None
    if meshcat is not None:
        params = MeshcatVisualizerParams(role=Role.kIllustration,
                                         publish_period=1.0 / scenario.recording.fps)
        visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)

    diagram = builder.Build()
    diagram.set_name(f"legato_{scenario.embodiment}_{scenario.task}")
    return LegatoDiagram(scenario, diagram, plant, scene_graph, robot, task, controller,
                         integrator, ik, gripper, success, tracking, camera, visualizer, meshcat,
                         X_home, recorder=recorder)
