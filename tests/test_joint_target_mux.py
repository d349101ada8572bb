"""JointTargetMux alone: groups land in port order; a bad grouping is refused."""

from __future__ import annotations

import numpy as np
import pytest

from legato_drake.systems.joint_target_mux import JointTargetMux


class _Joint:
    def __init__(self, index: int):
        self._index = index

    def index(self) -> int:
        return self._index


def test_groups_are_merged_in_port_order():
    joints = [_Joint(i) for i in range(5)]
    mux = JointTargetMux(joints, [[joints[3], joints[0]], [joints[1], joints[4], joints[2]]])
    context = mux.CreateDefaultContext()
    mux.get_input_port(0).FixValue(context, [30.0, 0.0, 3.0, 0.5])       # q3, q0, v3, v0
    mux.get_input_port(1).FixValue(context, [10.0, 40.0, 20.0, 1.0, 4.0, 2.0])
    np.testing.assert_array_equal(mux.get_output_port().Eval(context),
                                  [0, 10, 20, 30, 40, 0.5, 1, 2, 3, 4])


def test_groups_must_cover_every_joint_once():
    joints = [_Joint(i) for i in range(3)]
    with pytest.raises(ValueError, match="exactly once"):
        JointTargetMux(joints, [[joints[0]], [joints[0], joints[1]]])
