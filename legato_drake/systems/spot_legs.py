"""The leg follower: Spot's legs (or any legs laid out as Spot's) follow the body's desired pose
with the feet fixed on the ground (SPEC §4).

``SpotLegIK`` turns the body part of the whole-body IK's desired state into the legs' desired
state by the analytic leg IK of ``legato_drake/leg_kinematics.py`` (the body pose is six
joints whose positions are the body frame's world pose; see there), and
``add_leg_follower`` wires it for an embodiment that declares a ``LegFollower``
(``legato_drake/robot_types.py``).

Idealised, and said so in the docs: the body is held by its stiff virtual joints, not by the
legs; the legs only follow it so that the feet stay where they stand.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Joint
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import MatrixGain

from legato_drake import conventions
from legato_drake.leg_kinematics import (
    LEG_SIGNS,
    LEGS,
    NOMINAL_BODY_POSE,
    SPOT_LEG_GEOMETRY,
    LegGeometry,
    body_rotation,
    leg_ik,
    single_leg_ik,
    standing_foot_positions,
    standing_leg_angles,
)
from legato_drake.robot_types import RobotHandles

__all__ = ["LEGS", "LEG_SIGNS", "NOMINAL_BODY_POSE", "SPOT_LEG_GEOMETRY", "LegGeometry",
           "SpotLegIK", "add_leg_follower", "body_rotation", "leg_ik", "single_leg_ik",
           "standing_foot_positions", "standing_leg_angles"]


def add_leg_follower(builder: DiagramBuilder, plant: MultibodyPlant, robot: RobotHandles,
                     ik_desired_state: OutputPort) -> tuple[list[Joint], OutputPort]:
    """Adds the embodiment's ``LegFollower`` as a ``SpotLegIK`` fed by the body part of the
    IK's desired state ``ik_desired_state`` (``[q; v]`` of ``robot.controlled_joints``), the
    feet standing below the hips at the body's home pose; returns the leg joints and the
    port of their desired state ``[q; v]``."""
    follower = robot.embodiment.leg_follower
    if follower is None:
        raise ValueError(f"embodiment {robot.embodiment.name!r} has no leg_follower")
    names = [j.name() for j in robot.controlled_joints]
    n = len(names)
    select = np.zeros((12, 2 * n))
    for k, joint in enumerate(follower.body_joints):
        select[k, names.index(joint)] = 1.0
        select[6 + k, n + names.index(joint)] = 1.0
    home = robot.home
    body_home = np.array([home.get(joint, 0.0) for joint in follower.body_joints])
    feet = standing_foot_positions(body_home, follower.geometry, follower.ground_z)
    body = builder.AddNamedSystem("leg_follower_body_state", MatrixGain(select))
    legs = builder.AddNamedSystem("leg_follower_ik", SpotLegIK(
        feet, follower.geometry, conventions.IK_PERIOD, nominal_body_pose=body_home))
    builder.Connect(ik_desired_state, body.get_input_port())
    builder.Connect(body.get_output_port(), legs.get_body_desired_state_input_port())
    joints = [plant.GetJointByName(name, robot.robot) for name in follower.leg_joints]
    return joints, legs.get_leg_desired_state_output_port()


class SpotLegIK(LeafSystem):
    """Turns the body's desired state into the legs' desired state, feet fixed on the ground.

    Stateless and direct-feedthrough: the leg positions are ``leg_ik`` of the desired body
    pose; the leg velocities are the central difference of ``leg_ik`` along the desired body
    velocity over one ``period`` (the leg motion that follows the body over one IK step):
    ``(leg_ik(q + v period/2) - leg_ik(q - v period/2)) / period``. Outputs are clamped to the
    leg joint limits and always finite (a non-finite input holds the stance of
    ``nominal_body_pose`` at rest). By default the feet stand below the hip-y joints, on
    z = 0, with the body at ``nominal_body_pose`` (Spot's home pose by default).

    Input ports:
        body_desired_state (12): [x, y, z, roll, pitch, yaw] of the body joints, then their 6
        velocities (the body part of the whole-body IK's desired state).

    Output ports:
        leg_desired_state (24): the 12 leg joint positions in leg-joint order
        (fl_hip_x, fl_hip_y, fl_knee, fr_..., hl_..., hr_...), then their 12 velocities.
    """

    def __init__(self, foot_positions: np.ndarray | None = None,
                 geometry: LegGeometry = SPOT_LEG_GEOMETRY, period: float = conventions.IK_PERIOD,
                 nominal_body_pose: np.ndarray = NOMINAL_BODY_POSE):
        super().__init__()
        nominal = np.array(nominal_body_pose, dtype=float)
        if nominal.shape != (6,) or not np.all(np.isfinite(nominal)):
            raise ValueError(f"nominal_body_pose must be 6 finite numbers, got {nominal!r}")
        if foot_positions is None:
            foot_positions = standing_foot_positions(nominal, geometry)
        feet = np.array(foot_positions, dtype=float)
        if feet.shape != (4, 3) or not np.all(np.isfinite(feet)):
            raise ValueError(f"foot_positions must be a finite 4 x 3 array, got {feet!r}")
        if not period > 0.0:
            raise ValueError(f"period must be positive, got {period}")
        self._feet, self._geometry, self._period = feet, geometry, float(period)
        self._nominal = nominal
        self._lower, self._upper = geometry.lower_limits, geometry.upper_limits
        self._input = self.DeclareVectorInputPort("body_desired_state", 12)
        self._output = self.DeclareVectorOutputPort("leg_desired_state", 24, self._calc,
                                                    {self.all_input_ports_ticket()})

    @property
    def foot_positions(self) -> np.ndarray:
        """The fixed feet (4 x 3, world, ``LEGS`` order)."""
        return self._feet.copy()

    def get_body_desired_state_input_port(self):
        return self._input

    def get_leg_desired_state_output_port(self):
        return self._output

    def leg_state(self, body_state: np.ndarray) -> np.ndarray:
        """The 24-vector output for a 12-vector body desired state (no context needed)."""
        x = np.asarray(body_state, dtype=float)
        if x.shape != (12,) or not np.all(np.isfinite(x)):
            return np.concatenate([leg_ik(self._nominal, self._feet, self._geometry),
                                   np.zeros(12)])
        q, v = x[:6], x[6:]
        h = 0.5 * self._period
        positions = leg_ik(q, self._feet, self._geometry)
        velocities = (leg_ik(q + h * v, self._feet, self._geometry)
                      - leg_ik(q - h * v, self._feet, self._geometry)) / self._period
        return np.concatenate([np.clip(positions, self._lower, self._upper), velocities])

    def _calc(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.leg_state(self._input.Eval(context)))
