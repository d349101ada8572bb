"""GripperActuation alone: closing and opening at the stroke speed, NaN hold."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.systems.gripper_actuation import GripperActuation


def _finger_target(grasp: float, t: float, start: float | None = None) -> np.ndarray:
    system = GripperActuation(stroke_time=0.8)
    context = system.CreateDefaultContext()
    if start is not None:
        context.SetDiscreteState([start, 0.0])
    system.get_grasp_input_port().FixValue(context, [grasp])
    Simulator(system, context).AdvanceTo(t)
    return system.GetOutputPort("desired_state").Eval(context)


def test_starts_open():
    q = _finger_target(0.0, 0.0)
    np.testing.assert_allclose(q, [conventions.GRIPPER_OPEN] * 2 + [0, 0])


def test_closes_at_the_stroke_speed():
    speed = conventions.GRIPPER_OPEN / 0.8
    q = _finger_target(1.0, 0.4)
    assert q[0] == pytest.approx(conventions.GRIPPER_OPEN - 0.4 * speed, abs=speed * 0.011)
    assert q[2] == pytest.approx(-speed)
    q = _finger_target(1.0, 1.0)
    np.testing.assert_allclose(q, [0, 0, 0, 0], atol=1e-12)


def test_opens_again():
    q = _finger_target(0.0, 1.0, start=0.0)
    np.testing.assert_allclose(q[:2], conventions.GRIPPER_OPEN)


def test_nan_command_holds():
    q = _finger_target(np.nan, 0.5, start=0.02)
    np.testing.assert_allclose(q, [0.02, 0.02, 0, 0])
