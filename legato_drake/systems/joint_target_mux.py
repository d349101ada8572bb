"""Assembles the desired state of a robot's actuators from several groups of joints."""

from __future__ import annotations

import numpy as np
from pydrake.multibody.tree import Joint
from pydrake.systems.framework import BasicVector, Context, LeafSystem


class JointTargetMux(LeafSystem):
    """Merges ``[q; v]`` targets of disjoint joint groups into one ``[q; v]`` in port order.

    Used where the whole-body IK drives some joints and another system the rest (Spot: the
    IK drives body and arm, the leg IK the legs).

    Input ports:
        group_<i> (2 n_i): ``[q; v]`` of the i-th group's joints, in that group's order.

    Output ports:
        desired_state (2 N): ``[q; v]`` of ``joints`` (the robot's actuated joints, in the
        order of its desired-state input port).
    """

    def __init__(self, joints: list[Joint], groups: list[list[Joint]]):
        super().__init__()
        position = {j.index(): k for k, j in enumerate(joints)}
        covered = sorted(position[j.index()] for group in groups for j in group)
        if covered != list(range(len(joints))):
            raise ValueError("the joint groups must cover every actuated joint exactly once")
        self._n = len(joints)
        self._slots = [np.array([position[j.index()] for j in group]) for group in groups]
        self._inputs = [self.DeclareVectorInputPort(f"group_{i}", 2 * len(group))
                        for i, group in enumerate(groups)]
        self.DeclareVectorOutputPort("desired_state", 2 * self._n, self._calc,
                                     {self.all_input_ports_ticket()})

    def _calc(self, context: Context, output: BasicVector) -> None:
        x = np.zeros(2 * self._n)
        for port, slots in zip(self._inputs, self._slots, strict=True):
            value = port.Eval(context)
            x[slots] = value[:len(slots)]
            x[self._n + slots] = value[len(slots):]
        output.SetFromVector(x)
