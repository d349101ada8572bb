"""``LegatoEnv``: one LEGATO task on one robot as a Gymnasium environment.

One ``step`` is one 10 Hz policy step: the action is held by the diagram's
``ExternalController`` and executed exactly as a policy's would be (the target integrator
applies it, the whole-body IK retargets it at 100 Hz, the joint PD tracks at 500 Hz), and the
observation is what a LEGATO policy sees then: the gripper's two grayscale images, rendered at
the step, and the pose deltas of the last two actions (oldest first, zeros at the start, as
in the datasets). The episode is the one ``evaluate`` runs: the same diagram, the same seeded
scene for ``reset(seed=s)`` (trial i of ``evaluate`` uses seed ``10000 + i``), the same
success predicate and time limit (``episode.EpisodeRun``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from pydrake.geometry import ClippingRange, ColorRenderCamera, RenderCameraCore
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.sensors import CameraInfo

from legato_drake import conventions
from legato_drake.data.layout import HISTORY
from legato_drake.diagram import LegatoDiagram, build_diagram, object_bodies
from legato_drake.episode import EpisodeRun
from legato_drake.poses import pose_to_vector
from legato_drake.scenario import Scenario
from legato_drake.systems.stereo_camera import RENDERER_NAME

OBSERVE_OFFSET = conventions.CONTROLLER_OFFSET / 2
"""Where a step ends within the policy period: after the cameras rendered at ``t_k``, before
the action is consumed at ``t_k + TARGET_OFFSET``."""
MAX_TRANSLATION = 0.05
"""Bound of the action's translation components (m per step; the experts move < 2 cm)."""
MAX_ROTATION = 0.5
"""Bound of the action's rotation components (rad per step)."""


class LegatoEnv(gym.Env):
    """A LEGATO task (``lid``, ``cup``, ``ladle``) on a robot (a registered name, or a YAML
    robot through ``embodiment_file``). Observation: a Dict of ``left_gray``, ``right_gray``
    (uint8 H x W x 1), ``delta_positions`` and ``delta_eulers`` (float32, 6), and with
    ``privileged`` also ``tcp_commanded`` (7: the commanded gripper pose, xyz + wxyz) and
    ``object`` (7 per free body of the scene). Action: Box(7) ``[dx, dy, dz, droll, dpitch,
    dyaw, grasp]``, the pose delta in the previous commanded gripper frame and the grasp
    command (> 0.5 closes), as in the datasets. Reward 1 on success, else 0; ``terminated``
    on success; ``truncated`` at the task's time limit (``duration`` seconds after homing);
    ``info`` holds ``success``, ``reason`` (why the task is not done, from the success
    predicate), ``time`` (seconds since homing) and ``seed``. ``render_mode="rgb_array"``
    renders a third-person RGB frame of the scene (for videos)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, task: str = "lid", embodiment: str = "abstract",
                 embodiment_file: str | None = None, duration: float | None = None,
                 privileged: bool = False, render_mode: str | None = None):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: unknown {render_mode!r}; valid values: rgb_array")
        scenario = Scenario(embodiment=embodiment, embodiment_file=embodiment_file or "",
                            task=task, controller="external")
        if duration is not None:
            scenario.duration = float(duration)
        self.render_mode = render_mode
        self.privileged = privileged
        self.built: LegatoDiagram = build_diagram(scenario.validate())
        self._objects = object_bodies(self.built.plant, self.built.robot)
        camera = scenario.camera
        image = spaces.Box(0, 255, (camera.height, camera.width, 1), np.uint8)
        deltas = {name: spaces.Box(-bound, bound, (3 * HISTORY,), np.float32)
                  for name, bound in (("delta_positions", MAX_TRANSLATION),
                                      ("delta_eulers", MAX_ROTATION))}
        observation = {"left_gray": image, "right_gray": image, **deltas}
        if privileged:
            observation["tcp_commanded"] = spaces.Box(-np.inf, np.inf, (7,), np.float32)
            observation["object"] = spaces.Box(-np.inf, np.inf, (7 * len(self._objects),),
                                               np.float32)
        self.observation_space = spaces.Dict(observation)
        bound = np.array([MAX_TRANSLATION] * 3 + [MAX_ROTATION] * 3, np.float32)
        self.action_space = spaces.Box(np.r_[-bound, 0.0].astype(np.float32),
                                       np.r_[bound, 1.0].astype(np.float32), dtype=np.float32)
        self.run: EpisodeRun | None = None
        self._view: tuple[ColorRenderCamera, RigidTransform] | None = None
        self._steps = 0
        self._history = np.zeros((HISTORY, 6))

    @property
    def scenario(self) -> Scenario:
        """The scenario of the current episode (its seed is the scene's)."""
        return self.built.scenario

    def reset(self, *, seed: int | None = None, options: dict | None = None
              ) -> tuple[dict, dict]:
        """Starts the episode of scene seed ``seed`` (default: drawn from the environment's
        generator) and homes the robot; returns the first observation."""
        super().reset(seed=seed)
        scene = seed if seed is not None else int(self.np_random.integers(0, 2**31 - 1))
        self.built = dataclasses.replace(
            self.built, scenario=dataclasses.replace(self.built.scenario, seed=scene))
        self.run = EpisodeRun(self.built)
        self._view = None  # aimed at this scene's objects on the first render
        self._steps = 0
        self._history = np.zeros((HISTORY, 6))
        self.run.advance_to(conventions.HOMING_DURATION + OBSERVE_OFFSET)
        return self._observation(), self._info(False)

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        """Executes ``action`` (clipped to the action space) for one policy step (0.1 s)."""
        if self.run is None:
            raise RuntimeError("call reset() before step()")
        space = self.action_space
        action = np.clip(np.asarray(action, dtype=float).reshape(7), space.low, space.high)
        controller = self.built.controller
        controller.set_action(controller.GetMyMutableContextFromRoot(
            self.run.simulator.get_mutable_context()), action)
        self._steps += 1
        self.run.advance_to(conventions.HOMING_DURATION + OBSERVE_OFFSET +
                            self._steps * conventions.POLICY_PERIOD)
        self._history = np.concatenate([self._history[1:], action[None, :6]])
        success = bool(self.run.stopped == "success" or self.run.success_now())
        truncated = bool(not success and self.run.ended)
        return (self._observation(), float(success), success, truncated,
                self._info(success))

    def _observation(self) -> dict[str, np.ndarray]:
        built, context = self.built, self.run.context
        camera_context = built.camera.GetMyContextFromRoot(context)
        obs = {name: np.asarray(built.camera.GetOutputPort(name).Eval(camera_context),
                                dtype=np.uint8).reshape(self.observation_space[name].shape)
               for name in ("left_gray", "right_gray")}
        obs["delta_positions"] = self._history[:, 0:3].reshape(-1).astype(np.float32)
        obs["delta_eulers"] = self._history[:, 3:6].reshape(-1).astype(np.float32)
        if self.privileged:
            integrator = built.integrator
            obs["tcp_commanded"] = np.asarray(integrator.GetOutputPort("X_WG_commanded").Eval(
                integrator.GetMyContextFromRoot(context)), np.float32).reshape(7)
            plant_context = built.plant.GetMyContextFromRoot(context)
            obs["object"] = np.concatenate([pose_to_vector(body.EvalPoseInWorld(plant_context))
                                            for body in self._objects]).astype(np.float32)
        return obs

    def _info(self, success: bool) -> dict[str, Any]:
        report = self.built.success.evaluate(
            self.built.success.GetMyContextFromRoot(self.run.context))
        return {"success": success, "reason": "" if success else report.reason,
                "time": self.run.time - conventions.HOMING_DURATION,
                "seed": self.scenario.seed}

    def render(self) -> np.ndarray | None:
        """A third-person RGB frame (``RENDER_SIZE``) of the scene now, from a camera in
        front of and beside the task's objects, looking at them (``render_mode
        ="rgb_array"``; else None)."""
        if self.render_mode != "rgb_array" or self.run is None:
            return None
        built = self.built
        if self._view is None:
            self._view = _viewing_camera(self._objects_centre())
        query = built.camera.get_geometry_query_input_port().Eval(
            built.camera.GetMyContextFromRoot(self.run.context))
        world = query.inspector().world_frame_id()
        rgba = query.RenderColorImage(self._view[0], world, self._view[1])
        return np.ascontiguousarray(rgba.data[:, :, :3])

    def _objects_centre(self) -> np.ndarray:
        plant_context = self.built.plant.GetMyContextFromRoot(self.run.context)
        return np.mean([body.EvalPoseInWorld(plant_context).translation()
                        for body in self._objects], axis=0)

    def episode_result(self):
        """The ``EpisodeResult`` of the episode so far (as ``evaluate`` reports it)."""
        return self.run.result()


RENDER_SIZE = (320, 240)
"""Width and height of ``render()``'s frames."""
VIEW_OFFSET = np.array([0.9, -1.1, 0.7])
"""Where the third-person camera sits relative to the objects' centre (m, world frame)."""


def _viewing_camera(target: np.ndarray) -> tuple[ColorRenderCamera, RigidTransform]:
    """A pinhole camera at ``target + VIEW_OFFSET`` looking at ``target`` (Drake's camera
    frame: +z forward, +x right, +y down), and its pose in the world."""
    eye = target + VIEW_OFFSET
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    X_WC = RigidTransform(RotationMatrix(np.column_stack([right, down, forward])), eye)
    width, height = RENDER_SIZE
    core = RenderCameraCore(RENDERER_NAME, CameraInfo(width=width, height=height,
                                                      fov_y=np.radians(50.0)),
                            ClippingRange(0.05, 10.0), RigidTransform())
    return ColorRenderCamera(core, show_window=False), X_WC
