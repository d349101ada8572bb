"""The ExternalController alone, with its own context: it outputs what was set, holds it
through simulated time, and is never done."""

from __future__ import annotations

import numpy as np
from pydrake.systems.analysis import Simulator

from legato_drake.systems.external_controller import ExternalController


def test_outputs_the_action_set_and_holds_it():
    controller = ExternalController()
    simulator = Simulator(controller)
    context = simulator.get_mutable_context()
    np.testing.assert_array_equal(controller.GetOutputPort("action").Eval(context), np.zeros(7))
    action = np.array([0.01, -0.02, 0.003, 0.1, 0.0, -0.1, 1.0])
    controller.set_action(context, action)
    simulator.AdvanceTo(1.0)
    np.testing.assert_array_equal(controller.GetOutputPort("action").Eval(context), action)
    np.testing.assert_array_equal(controller.action(context), action)
    assert controller.GetOutputPort("done").Eval(context)[0] == 0.0
