"""Feed-forward gravity torques for a robot's actuators, at its commanded posture."""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Joint
from pydrake.systems.framework import BasicVector, Context, LeafSystem


class GravityCompensation(LeafSystem):
    """Outputs ``u = -tau_g(q_cmd)`` for the given actuated joints.

    Added to the plant's actuation input, it cancels gravity so that the plant's joint PD
    (which runs implicitly at the physics rate) only corrects tracking errors; the reference
    implementation had none and its Panda sagged by about 7 mm. It is evaluated at the
    commanded posture (the PD's set point, millimetres from the measured one), so its output
    changes only when the IK updates and Drake's cache recomputes it at 100 Hz, not 500 Hz.

    Input ports:
        desired_state (2n): [q_cmd; v_cmd] of ``joints``, as sent to the joint PD.

    Output ports:
        actuation (n): feed-forward effort for ``joints``, in the same order.
    """

    def __init__(self, plant: MultibodyPlant, joints: list[Joint]):
        super().__init__()
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        self._q_full = plant.GetPositions(self._plant_context).copy()
        self._q_index = np.array([j.position_start() for j in joints])
        self._v_index = np.array([j.velocity_start() for j in joints])
        n = len(joints)
        self._desired = self.DeclareVectorInputPort("desired_state", 2 * n)
        self.DeclareVectorOutputPort("actuation", n, self._calc,
                                     {self.all_input_ports_ticket()})

    def get_desired_state_input_port(self):
        return self._desired

    def _calc(self, context: Context, output: BasicVector) -> None:
        self._q_full[self._q_index] = self._desired.Eval(context)[:len(self._q_index)]
        self._plant.SetPositions(self._plant_context, self._q_full)
        tau_g = self._plant.CalcGravityGeneralizedForces(self._plant_context)
        output.SetFromVector(-tau_g[self._v_index])
