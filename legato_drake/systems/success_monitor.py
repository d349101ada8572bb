"""Evaluates the task's success predicate on the plant state while the episode runs."""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from legato_drake import conventions
from legato_drake.tasks.base import SuccessReport, Task


class SuccessMonitor(LeafSystem):
    """Checks ``task.evaluate`` every ``period`` from ``t_start`` on.

    Input ports:
        plant_state: the plant's full state.

    Output ports:
        success (1): 1 while the predicate held at the last check, else 0.
        first_success_time (1): time of the first check at which it held (NaN before).

    State: discrete [success, first success time].
    """

    def __init__(self, plant: MultibodyPlant, task: Task,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD):
        super().__init__()
        self._plant, self._task = plant, task
        self._plant_context = plant.CreateDefaultContext()
        self._plant_state = self.DeclareVectorInputPort(
            "plant_state", plant.num_positions() + plant.num_velocities())
        self._state = self.DeclareDiscreteState(np.array([0.0, np.nan]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, t_start, self._check)
        self.DeclareVectorOutputPort("success", 1, self._calc_success, {self.xd_ticket()})
        self.DeclareVectorOutputPort("first_success_time", 1, self._calc_time,
                                     {self.xd_ticket()})

    def get_plant_state_input_port(self):
        return self._plant_state

    def evaluate(self, context: Context) -> SuccessReport:
        """The predicate on the plant state currently on the input port."""
        self._plant.SetPositionsAndVelocities(self._plant_context,
                                              self._plant_state.Eval(context))
        return self._task.evaluate(self._plant, self._plant_context)

    def _check(self, context: Context, discrete_state: DiscreteValues) -> None:
        ok = self.evaluate(context).success
        first = context.get_discrete_state(self._state).get_value()[1]
        if ok and np.isnan(first):
            first = context.get_time()
        discrete_state.set_value(self._state, [float(ok), first])

    def _calc_success(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[:1])

    def _calc_time(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[1:])
