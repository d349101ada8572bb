"""Records one dataset sample per policy step: images, action, poses, privileged state."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Body, Frame
from pydrake.systems.framework import Context, EventStatus, LeafSystem, ValueProducer

from legato_drake import conventions
from legato_drake.poses import pose_to_vector

RECORDER_OFFSET = 0.0015
"""Phase (s) of the recorder within a policy period: after the controller acted
(``conventions.CONTROLLER_OFFSET``, 1 ms) and before the target integrator applies the action
(``conventions.TARGET_OFFSET``, 2 ms)."""

SAMPLE_KEYS = ("time", "action", "tcp_commanded", "tcp_measured", "object", "fingers",
               "state", "left_gray", "right_gray")
"""Fields of one recorded sample (the two images only when the recorder has cameras)."""


@dataclass
class EpisodeLog:
    """The samples recorded so far, one list entry per policy step (a mutable log that lives
    in the recorder's context, like ``VectorLogSink``'s)."""

    samples: dict[str, list[np.ndarray]] = field(
        default_factory=lambda: {key: [] for key in SAMPLE_KEYS})

    def __len__(self) -> int:
        return len(self.samples["time"])

    def append(self, sample: dict[str, np.ndarray]) -> None:
        """Adds one sample (every key of ``SAMPLE_KEYS`` it has)."""
        for key, value in sample.items():
            self.samples[key].append(value)

    def clear(self) -> None:
        """Forgets every sample."""
        for values in self.samples.values():
            values.clear()

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The log as stacked arrays, first axis = step; keys with no samples are left out
        (e.g. the images of a recorder without cameras)."""
        return {key: np.stack(values) for key, values in self.samples.items() if values}


class EpisodeRecorder(LeafSystem):
    """Logs one sample per policy step from ``t_start`` on, for the demonstration dataset.

    Sample k is taken by a periodic *publish* event at ``t_k + offset`` (t_k = ``t_start`` +
    k ``period``; default offset 1.5 ms): the camera rendered at t_k, the controller computed
    its action at t_k + 1 ms, and the target integrator has not yet applied it (t_k + 2 ms). So
    a sample holds the images the controller saw, the action it took, and the commanded TCP pose
    *before* that action (the frame the action is expressed in): ``tcp_commanded[k + 1] =
    tcp_commanded[k] * action[k]``. The plant state is the one in the context then (within one
    2 ms physics step of t_k).

    The log lives in the context (a cache entry used as mutable storage, as Drake's
    ``VectorLogSink`` does), so the system holds no hidden state: read it with
    ``log(context)``, empty it with ``clear(context)``.

    Input ports:
        action (7): the controller's action [pose delta (6), grasp].
        X_WG_commanded (7): the commanded TCP pose [xyz, quaternion wxyz].
        plant_state: the plant's full state [q; v].
        left_gray, right_gray (numpy uint8 H x W x 1): only with ``images=True``.

    Each sample (``EpisodeLog``): ``time``, ``action`` (7), ``tcp_commanded`` (7),
    ``tcp_measured`` (7, the TCP pose computed from the plant state), ``object`` (7 per object
    body: [xyz, quaternion wxyz]), ``fingers`` (the finger joint positions), ``state`` (the
    plant's [q; v]), and with images ``left_gray``, ``right_gray``.

    State: none (the log is a cache entry of the context).
    """

    def __init__(self, plant: MultibodyPlant, tcp_frame: Frame, images: bool = True,
                 object_bodies: Sequence[Body] | None = None,
                 finger_joints: Sequence[str] = conventions.GRIPPER_FINGER_JOINTS,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = RECORDER_OFFSET):
        super().__init__()
        self._plant, self._tcp_frame = plant, tcp_frame
        self._plant_context = plant.CreateDefaultContext()
        if object_bodies is None:
            object_bodies = [plant.get_body(i) for i in sorted(plant.GetFloatingBaseBodies())]
        self._bodies = list(object_bodies)
        self._fingers = [plant.GetJointByName(name) for name in finger_joints]
        self._t_start, self._images = t_start, images
        self._action = self.DeclareVectorInputPort("action", 7)
        self._commanded = self.DeclareVectorInputPort("X_WG_commanded", 7)
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities())
        self._cameras = {}
        if images:
            blank = AbstractValue.Make(np.zeros((1, 1, 1), dtype=np.uint8))
            self._cameras = {name: self.DeclareAbstractInputPort(name, blank)
                             for name in ("left_gray", "right_gray")}
        self._log = self.DeclareCacheEntry(
            "episode log", ValueProducer(allocate=lambda: AbstractValue.Make(EpisodeLog()),
                                         calc=ValueProducer.NoopCalc),
            {self.nothing_ticket()})
        self.DeclarePeriodicPublishEvent(period, t_start + offset, self._record)

    @property
    def object_body_names(self) -> list[str]:
        """Names of the bodies whose poses make up ``object``, in order."""
        return [body.name() for body in self._bodies]

    @property
    def has_images(self) -> bool:
        """Whether samples carry the two camera images."""
        return self._images

    def get_action_input_port(self):
        return self._action

    def get_commanded_pose_input_port(self):
        return self._commanded

    def get_plant_state_input_port(self):
        return self._plant_state

    def get_image_input_ports(self):
        """The (left_gray, right_gray) input ports (empty without images)."""
        return tuple(self._cameras.values())

    def log(self, context: Context) -> EpisodeLog:
        """The log held in ``context`` (this system's own context)."""
        self.ValidateContext(context)
        return self._log.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()

    def clear(self, context: Context) -> None:
        """Empties the log held in ``context``."""
        self.log(context).clear()

    def _record(self, context: Context) -> EventStatus:
        if context.get_time() < self._t_start:
            return EventStatus.DidNothing()
        self.log(context).append(self.sample(context))
        return EventStatus.Succeeded()

    def sample(self, context: Context) -> dict[str, np.ndarray]:
        """The sample of the inputs in ``context`` (what a step records; a state policy
        computes its observation with this very code at rollout)."""
        x = self._plant_state.Eval(context)
        self._plant.SetPositionsAndVelocities(self._plant_context, x)
        X_WG = self._tcp_frame.CalcPoseInWorld(self._plant_context)
        objects = [pose_to_vector(self._plant.EvalBodyPoseInWorld(self._plant_context, b))
                   for b in self._bodies]
        sample = {
            "time": np.array(context.get_time()),
            "action": np.array(self._action.Eval(context), dtype=float),
            "tcp_commanded": np.array(self._commanded.Eval(context), dtype=float),
            "tcp_measured": pose_to_vector(X_WG),
            "object": np.concatenate(objects) if objects else np.zeros(0),
            "fingers": np.array([j.GetOnePosition(self._plant_context)
                                 for j in self._fingers]),
            "state": np.array(x, dtype=float),
        }
        for name, port in self._cameras.items():
            sample[name] = np.array(port.Eval(context), dtype=np.uint8, copy=True)
        return sample
