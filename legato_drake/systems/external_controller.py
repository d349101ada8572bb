"""A controller whose actions come from outside the diagram (a Gymnasium agent, a notebook)."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem


class ExternalController(LeafSystem):
    """Holds the action that someone outside the diagram set last (``set_action``) and
    outputs it, with the same ports as the other controllers; between two ``set_action``
    calls the action holds. The diagram's target integrator consumes it at each policy step
    (``t_k + TARGET_OFFSET``), so an action set before the step is the one executed then.

    Output ports:
        action (7): [pose delta in the previous commanded gripper frame (6), grasp].
        done (1): always 0 (the caller decides when the episode ends).
    """

    def __init__(self):
        super().__init__()
        self._action = self.DeclareDiscreteState(7)
        self.DeclareStateOutputPort("action", self._action)
        self.DeclareVectorOutputPort("done", 1, self._calc_done, {self.nothing_ticket()})

    def set_action(self, context: Context, action: np.ndarray) -> None:
        """Sets the action held in ``context`` (this system's context)."""
        action = np.asarray(action, dtype=float).reshape(7)
        context.get_mutable_discrete_state(self._action).SetFromVector(action)

    def action(self, context: Context) -> np.ndarray:
        """The action held in ``context``."""
        return context.get_discrete_state(self._action).CopyToVector()

    def _calc_done(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, 0.0)
