"""A trained policy (pi_H) as a 10 Hz controller: a drop-in for the scripted demonstrator."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from legato_drake import conventions
from legato_drake.data.derived import VALUES_PER_BODY, read_observation
from legato_drake.data.layout import HISTORY, HISTORY_KEYS, IMAGE_KEYS
from legato_drake.data.torch_dataset import image_to_tensor
from legato_drake.errors import ConfigError
from legato_drake.learning.checkpoint import Checkpoint, load_checkpoint
from legato_drake.systems.episode_recorder import EpisodeRecorder


@dataclass(frozen=True)
class PolicyState:
    """What the controller carries from one step to the next (its abstract state)."""

    step: int
    """Controller steps taken."""
    policy: object
    """The policy family's own rollout state (opaque here; e.g. the LSTM state)."""
    history: np.ndarray
    """(2, 6) the pose deltas of the last two actions, oldest first (zeros at the start)."""
    action: tuple[float, ...]
    """The current action (7)."""
    plan: tuple[tuple[float, ...], ...] = ()
    """Actions of the last predicted chunk still to execute, next first."""


class PolicyController(LeafSystem):
    """Runs a trained LEGATO / BC-RNN policy every ``period`` (same ports and event phase as
    ``ScriptedDemonstrator``: it acts at ``t_k + CONTROLLER_OFFSET``, after the camera rendered
    at ``t_k``).

    Each step it builds the observation the policy was trained on: the pose-delta history
    (``delta_positions``, ``delta_eulers``: its own last two actions, oldest first, zeros
    before the first ones, as ``data.layout.delta_history``), plus either the two camera
    images (``image_to_tensor``: the preprocessing of training) or the privileged state
    features, computed by the ``EpisodeRecorder`` ``features`` itself (the very code that
    recorded the dataset) and ``data.derived.read_observation`` (the code that derives
    observations for training). The policy (any ``learning.family.PolicyFamily``) predicts a
    chunk of actions from the observation and its own rollout state, which the controller
    keeps without looking into it (``observe`` shows it every step's observation); the
    controller executes the first ``execute_steps`` of the chunk, one per step, then asks
    again (receding horizon). For the recurrent policies
    the chunk is one action (the low-noise GMM mode) and the state is the LSTM's, reset every
    ``seq_length`` steps (the training horizon), or the last ``seq_length`` frames' features
    (``rnn_memory: window``).

    Input ports (by the policy's observation mode):
        image: left_gray, right_gray (numpy uint8 H x W x 1).
        state: plant_state (the plant's [q; v]), X_WG_commanded (7, [xyz, quaternion wxyz]).

    Output ports:
        action (7): [dx, dy, dz, droll, dpitch, dyaw, grasp].
        done (1): always 0 (a policy never says it is done; the episode's time limit or
            success ends it).

    ``scene_seed`` is the episode's scene seed, which a stochastic policy may draw its
    rollout noise from (a Diffusion Policy with ``rollout_noise: scene``).

    ``threads`` sets torch's (process-wide) thread count: one by default, so that every entry
    point (``evaluate``, a scenario, a notebook) computes the same actions bit for bit; None
    leaves it as it is.

    State: abstract ``PolicyState`` (step, the policy's rollout state, pose-delta history,
    action, the rest of the current chunk). The
    recorder's scratch context used to compute state features holds nothing between steps.
    """

    def __init__(self, checkpoint: Checkpoint | str | Path,
                 features: EpisodeRecorder | None = None,
                 t_start: float = conventions.HOMING_DURATION,
                 period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.CONTROLLER_OFFSET,
                 threads: int | None = 1, scene_seed: int = 0):
        super().__init__()
        if threads is not None:
            torch.set_num_threads(threads)
        ckpt = checkpoint if isinstance(checkpoint, Checkpoint) else load_checkpoint(checkpoint)
        self._policy = ckpt.policy.to("cpu").eval()
        self._config = ckpt.config
        self._t_start = t_start
        self._images = {}
        self._state_keys = [k for k in ckpt.config.obs_keys
                            if k not in HISTORY_KEYS and k not in IMAGE_KEYS]
        self._features = features
        if ckpt.config.obs_mode == "image":
            blank = AbstractValue.Make(np.zeros((1, 1, 1), dtype=np.uint8))
            self._images = {k: self.DeclareAbstractInputPort(k, blank)
                            for k in ckpt.config.obs_keys if k in IMAGE_KEYS}
        else:
            if features is None:
                raise ValueError("a state-mode policy needs the EpisodeRecorder 'features' "
                                 "that computes its state observations")
            for key in set(self._state_keys) & set(VALUES_PER_BODY):
                trained = len(ckpt.stats[key]["mean"]) // VALUES_PER_BODY[key]
                here = len(features.object_body_names)
                if trained != here:
                    raise ConfigError(
                        f"the policy was trained with {trained} object bodies, this scene "
                        f"has {here} ({', '.join(features.object_body_names)}): a "
                        "state policy runs on the task it was trained on")
            plant_port = features.get_plant_state_input_port()
            self._plant_state = self.DeclareVectorInputPort("plant_state", plant_port.size())
            self._commanded = self.DeclareVectorInputPort("X_WG_commanded", 7)
            self._scratch = features.CreateDefaultContext()
            features.get_action_input_port().FixValue(self._scratch, np.zeros(7))
        initial = PolicyState(0, self._policy.initial_state(scene_seed),
                              np.zeros((HISTORY, 6)), (0.0,) * 7)
        self._state = self.DeclareAbstractState(AbstractValue.Make(initial))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, t_start + offset, self._step)
        self.DeclareVectorOutputPort("action", 7, self._calc_action, {self.all_state_ticket()})
        self.DeclareVectorOutputPort("done", 1, self._calc_done, {self.nothing_ticket()})

    @property
    def config(self):
        """The policy's ``LearningConfig``."""
        return self._config

    @property
    def obs_mode(self) -> str:
        """``image`` or ``state``."""
        return self._config.obs_mode

    def get_image_input_ports(self):
        """The (left_gray, right_gray) input ports (empty for a state policy)."""
        return tuple(self._images.values())

    def get_plant_state_input_port(self):
        return self._plant_state

    def get_commanded_pose_input_port(self):
        return self._commanded

    def policy_state(self, context: Context) -> PolicyState:
        """The controller's state in ``context``."""
        return context.get_abstract_state(self._state).get_value()

    def observation(self, context: Context, history: np.ndarray) -> dict[str, torch.Tensor]:
        """The policy's raw observation (batch of one) in ``context`` given the history."""
        obs = {"delta_positions": torch.from_numpy(
                   history[:, 0:3].reshape(1, -1).astype(np.float32)),
               "delta_eulers": torch.from_numpy(
                   history[:, 3:6].reshape(1, -1).astype(np.float32))}
        for key, port in self._images.items():
            obs[key] = image_to_tensor(port.Eval(context))[None]
        if self._state_keys:
            rec = self._features
            rec.get_plant_state_input_port().FixValue(self._scratch,
                                                      self._plant_state.Eval(context))
            rec.get_commanded_pose_input_port().FixValue(self._scratch,
                                                         self._commanded.Eval(context))
            sample = rec.sample(self._scratch)  # the recorder's own feature code
            for key in self._state_keys:
                value = read_observation(sample, key)  # derived ones as in training
                obs[key] = torch.from_numpy(value[None].astype(np.float32))
        return obs

    def _step(self, context: Context, state: State) -> None:
        current = self.policy_state(context)
        plan = current.plan
        obs = self.observation(context, current.history)
        with torch.no_grad():
            policy_state = self._policy.observe(obs, current.policy)
            if not plan:
                chunk, policy_state = self._policy.act(obs, policy_state)
                steps = max(1, min(self._policy.execute_steps, chunk.shape[1]))
                plan = tuple(tuple(float(a) for a in row) for row in chunk[0, :steps].numpy())
        action = np.asarray(plan[0])
        history = np.concatenate([current.history[1:], action[None, :6]])
        new = PolicyState(current.step + 1, policy_state, history, plan[0], plan[1:])
        state.get_mutable_abstract_state(self._state).set_value(new)

    def _calc_action(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.policy_state(context).action)

    def _calc_done(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector([0.0])
