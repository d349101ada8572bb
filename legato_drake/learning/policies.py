"""The LEGATO hybrid policy and the BC-RNN baseline: encoders -> LSTM -> MLP -> GMM heads.

``RecurrentGMMPolicy`` (SPEC §8) reads raw observations (it normalises low-dim inputs and
actions itself with the training statistics it holds as buffers):

* image mode: per camera a conv trunk + spatial softmax + linear (``encoders.ImageEncoder``),
  concatenated with the 6 x ``history`` pose-delta inputs (none where ``history`` is 0, as in
  the small configs); state mode: the privileged state features instead of the images.
* an LSTM, an MLP (ReLU), then the heads:

  - ``legato``: a ``gmm_modes``-component GMM over the 6 pose-delta dims (softplus scales +
    ``min_std``) and a separate 2-class grasp head (logits; cross-entropy on the logits);
  - ``bc_rnn``: one GMM over all 7 action dims; the grasp is its 7th dim thresholded at 0.5.

Loss = nll_weight * NLL + grasp_weight * CE + invariant_weight * L_invar, where L_invar
(``invariants.invariant_loss``) compares the DHB invariants of the demonstrated history plus
the *predicted* action with those of the history plus the demonstrated action; the prediction
is the mean of the most likely GMM component (``gmm_mean_of_most_likely_mode``), which is
differentiable w.r.t. the means, so L_invar trains the heads, the LSTM and the encoders.
Rollout uses the same low-noise mode.

With ``object_aux_weight`` > 0 (image mode), training adds that weight times the mean squared
error of ``object_head.ObjectHead`` (the ``aux`` term), which regresses the objects' poses
from the image features: privileged supervision that makes the encoder locate the objects.
The head is not used at rollout.

With ``ema`` the policy also holds ``ema``, a copy of itself whose weights are the moving
average of the trained ones (``family.update_average``); in eval mode ``forward`` and
``losses`` (validation), and ``act`` and ``estimate_objects`` always, run the copy.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F  # noqa: N812 - the usual torch name
from torch import distributions as D  # noqa: N812
from torch import nn

from legato_drake.data.layout import HISTORY, HISTORY_KEYS, IMAGE_KEYS
from legato_drake.invariants import (
    gmm_mean_of_most_likely_mode,
    history_from_observations,
    invariant_loss,
)
from legato_drake.learning.config import LearningConfig
from legato_drake.learning.encoders import ImageEncoder, encode_sequence
from legato_drake.learning.family import PolicyFamily, Stats, masked_mean, update_average
from legato_drake.learning.normalization import Normalizer
from legato_drake.learning.object_head import ObjectHead, rename_legacy_keys

Hidden = tuple[torch.Tensor, torch.Tensor]


@dataclass
class PolicyOutput:
    """The heads' outputs for (B, T) steps (normalised action space)."""

    logits: torch.Tensor
    """(B, T, K) mixture logits."""
    means: torch.Tensor
    """(B, T, K, D) component means."""
    scales: torch.Tensor
    """(B, T, K, D) component standard deviations."""
    grasp_logits: torch.Tensor | None
    """(B, T, 2) grasp logits (LEGATO only)."""

    def distribution(self) -> D.MixtureSameFamily:
        """The GMM over the normalised action dims."""
        return D.MixtureSameFamily(D.Categorical(logits=self.logits),
                                   D.Independent(D.Normal(self.means, self.scales), 1))


@dataclass(frozen=True)
class RecurrentState:
    """The rollout state of a recurrent policy."""

    steps: int
    """Actions taken since the episode began."""
    hidden: tuple[np.ndarray, np.ndarray] | None
    """The LSTM state (h, c); None at the start (``rnn_memory: reset``)."""
    window: tuple[np.ndarray, ...] = ()
    """The LSTM's input features (B, F) of the last ``seq_length - 1`` frames, oldest first
    (``rnn_memory: window``)."""


class RecurrentGMMPolicy(PolicyFamily):
    """LEGATO (``algo: legato``) or BC-RNN (``algo: bc_rnn``); see the module docstring.
    One action per ``act``; the LSTM remembers at most ``seq_length`` steps (the training
    horizon), as ``rnn_memory`` says."""

    loss_terms = ("nll", "ce", "invar", "total")

    def __init__(self, config: LearningConfig, stats: Stats):
        super().__init__(config, stats)
        self.image_keys = [k for k in config.obs_keys if k in IMAGE_KEYS]
        self.low_dim_keys = [k for k in config.obs_keys if k not in IMAGE_KEYS]
        missing = [k for k in (*self.low_dim_keys, "actions") if k not in stats]
        if missing:
            raise ValueError(f"normalisation statistics lack {', '.join(missing)}")
        # The history keys hold HISTORY steps of 3 values, oldest first; the network sees
        # the last ``config.history`` of them.
        self.history_columns = slice(3 * (HISTORY - config.history), 3 * HISTORY)
        self.normalizers = nn.ModuleDict({
            k: Normalizer(*(np.asarray(stats[k][s])[self._columns(k)]
                            for s in ("mean", "std")))
            for k in (*self.low_dim_keys, "actions")})
        self.encoders = nn.ModuleDict({
            k: ImageEncoder.from_config(config) for k in self.image_keys})
        in_dim = sum(len(np.asarray(stats[k]["mean"])[self._columns(k)])
                     for k in self.low_dim_keys)
        in_dim += config.feature_dim * len(self.image_keys)
        self.rnn = nn.LSTM(in_dim, config.rnn_hidden, config.rnn_layers, batch_first=True)
        layers: list[nn.Module] = []
        width = config.rnn_hidden
        for dim in config.mlp_dims:
            layers += [nn.Linear(width, dim), nn.ReLU()]
            width = dim
        self.mlp = nn.Sequential(*layers)
        self.action_dims = 6 if config.algo == "legato" else 7
        K = config.gmm_modes
        self.logits_head = nn.Linear(width, K)
        self.means_head = nn.Linear(width, K * self.action_dims)
        self.scales_head = nn.Linear(width, K * self.action_dims)
        self.grasp_head = nn.Linear(width, 2) if config.algo == "legato" else None
        self.object_head = None
        if config.object_aux_weight > 0:
            self.object_head = ObjectHead(config.feature_dim * len(self.image_keys), stats)
            self.loss_terms = ("nll", "ce", "invar", "aux", "total")
            self._register_load_state_dict_pre_hook(rename_legacy_keys)
        self.ema: RecurrentGMMPolicy | None = None
        if config.ema:  # registered last: the trained parameters keep their order
            self.ema = copy.deepcopy(self, {id(config): config}).requires_grad_(False)

    def _columns(self, key: str) -> slice:
        """The columns of low-dim observation ``key`` the network reads."""
        return self.history_columns if key in HISTORY_KEYS else slice(None)

    def _low_dim(self, key: str, value: torch.Tensor) -> torch.Tensor:
        """A normalised low-dim input; in training, the history perturbed as configured
        (``history_noise``, ``history_dropout``)."""
        x = self.normalizers[key](value[..., self._columns(key)])
        cfg = self.config
        if self.training and key in HISTORY_KEYS:
            if cfg.history_noise > 0:
                x = x + cfg.history_noise * torch.randn_like(x)
            if cfg.history_dropout > 0:
                keep = torch.rand(x.shape[0], *(1,) * (x.dim() - 1), device=x.device)
                x = x * (keep >= cfg.history_dropout).to(x.dtype)
        return x

    def features(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """Raw observations (B, T, ...) -> the LSTM's input (B, T, F)."""
        parts = [encode_sequence(self.encoders[k], obs[k]) for k in self.image_keys]
        parts += [self._low_dim(k, obs[k]) for k in self.low_dim_keys]
        return torch.cat(parts, -1)

    def forward(self, obs: Mapping[str, torch.Tensor], hidden: Hidden | None = None
                ) -> tuple[PolicyOutput, Hidden]:
        """The heads' outputs for raw observations (B, T, ...), and the new RNN state (in
        eval mode, the weight average's if there is one)."""
        if self.ema is not None and not self.training:
            return self.ema(obs, hidden)
        return self._heads(self.features(obs), hidden)

    def _heads(self, features: torch.Tensor, hidden: Hidden | None = None
               ) -> tuple[PolicyOutput, Hidden]:
        """The heads' outputs for the LSTM's input features (B, T, F)."""
        y, hidden = self.rnn(features, hidden)
        y = self.mlp(y)
        B, T = y.shape[:2]
        K, Dm = self.config.gmm_modes, self.action_dims
        means = self.means_head(y).reshape(B, T, K, Dm)
        scales = F.softplus(self.scales_head(y)).reshape(B, T, K, Dm) + self.config.min_std
        grasp = self.grasp_head(y) if self.grasp_head is not None else None
        return PolicyOutput(self.logits_head(y), means, scales, grasp), hidden

    def mode_action(self, out: PolicyOutput) -> torch.Tensor:
        """The low-noise action (B, T, 7) in raw units: the mean of the most likely component
        (differentiable w.r.t. the means), grasp in {0, 1}."""
        mean = gmm_mean_of_most_likely_mode(out.logits, out.means)
        delta = self._raw_pose_delta(mean)
        if out.grasp_logits is not None:
            grasp = out.grasp_logits.argmax(-1).to(delta.dtype)
        else:
            action_norm = self.normalizers["actions"]
            grasp = (mean[..., 6] * action_norm.std[6] + action_norm.mean[6] >= 0.5)
            grasp = grasp.to(delta.dtype)
        return torch.cat([delta, grasp[..., None]], -1)

    def rollout_action(self, out: PolicyOutput) -> torch.Tensor:
        """The action a rollout executes (B, T, 7): ``mode_action``, or with ``gmm_action:
        mixture_mean`` its pose delta replaced by the mixture's mean (the grasp unchanged)."""
        action = self.mode_action(out)
        if self.config.gmm_action == "most_likely":
            return action
        mean = (torch.softmax(out.logits, -1)[..., None] * out.means).sum(-2)
        return torch.cat([self._raw_pose_delta(mean), action[..., 6:]], -1)

    def _raw_pose_delta(self, normalised: torch.Tensor) -> torch.Tensor:
        """The pose delta (..., 6) in raw units of a normalised action (..., 6 or 7)."""
        action_norm = self.normalizers["actions"]
        return normalised[..., :6] * action_norm.std[:6] + action_norm.mean[:6]

    def _trained(self, named: Iterator[tuple[str, torch.Tensor]]) -> Iterator[torch.Tensor]:
        """The trained copy's tensors of ``named_parameters()`` or ``named_buffers()``."""
        return (value for name, value in named if not name.startswith("ema."))

    def after_step(self, step: int) -> None:
        if self.ema is not None:
            update_average(self.ema, self._trained(self.named_parameters()),
                           self._trained(self.named_buffers()), step, self.config.ema_decay)

    def rollout_state_dict(self) -> dict[str, torch.Tensor]:
        """With ``ema``, the average alone (what a rollout runs)."""
        state = self.state_dict()
        return state if self.ema is None else {
            k: v for k, v in state.items() if k.startswith("ema.")}

    def load_rollout_state_dict(self, state: Mapping[str, torch.Tensor]) -> None:
        """With ``ema``, the average, copied into the trained weights too (where a rollout
        never reads them)."""
        if self.ema is not None:
            state = {**state, **{k[len("ema."):]: v for k, v in state.items()
                                 if k.startswith("ema.")}}
        self.load_state_dict(state)

    def losses(self, batch: Mapping) -> dict[str, torch.Tensor]:
        """The loss terms of a batch of sequences (``DemoSequenceDataset`` items, collated):
        ``nll``, ``ce`` (0 for BC-RNN), ``invar``, ``aux`` (with an object head) and the
        weighted ``total``; padded steps are left out. In eval mode, those of the weight
        average if there is one."""
        if self.ema is not None and not self.training:
            return self.ema.losses(batch)
        cfg = self.config
        obs, actions = batch["obs"], batch["actions"]
        mask = batch["pad_mask"]
        features = self.features(obs)
        out, _ = self._heads(features)
        target = self.normalizers["actions"](actions)[..., :self.action_dims]
        nll = masked_mean(-out.distribution().log_prob(target), mask)
        if out.grasp_logits is not None:
            ce_steps = F.cross_entropy(out.grasp_logits.flatten(0, 1),
                                       (actions[..., 6] > 0.5).long().flatten(),
                                       reduction="none").reshape(mask.shape)
            ce = masked_mean(ce_steps, mask)
        else:
            ce = torch.zeros((), dtype=nll.dtype, device=nll.device)
        if cfg.invariant_weight > 0:
            history = history_from_observations(obs["delta_positions"], obs["delta_eulers"])
            predicted = self.mode_action(out)[..., :6]
            invar = masked_mean(invariant_loss(history, predicted, actions[..., :6],
                                                reduction="none", eps=cfg.invariant_eps,
                                                turn_eps=cfg.invariant_turn_eps,
                                                tail=cfg.invariant_tail),
                                 mask)
        else:
            invar = torch.zeros((), dtype=nll.dtype, device=nll.device)
        total = cfg.nll_weight * nll + cfg.grasp_weight * ce + cfg.invariant_weight * invar
        terms = {"nll": nll, "ce": ce, "invar": invar}
        if self.object_head is not None:  # the image features lead ``features``
            terms["aux"] = self.object_head.loss(features, obs, mask)
            total = total + cfg.object_aux_weight * terms["aux"]
        return {**terms, "total": total}

    @torch.no_grad()
    def estimate_objects(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """What the auxiliary head reads from raw observations (B, T, ...): ``object_in_tcp``
        (B, T, 9k) in raw units, for diagnostics (``scripts/legato_fit.py``); the policy never
        acts on it. Needs ``object_aux_weight`` > 0."""
        if self.object_head is None:
            raise ValueError("this policy has no object head (object_aux_weight is 0)")
        if self.ema is not None:
            return self.ema.estimate_objects(obs)
        return self.object_head.estimate(self.features(obs))

    def initial_state(self, scene_seed: int = 0) -> RecurrentState:
        return RecurrentState(0, None)

    @torch.no_grad()
    def act(self, obs: Mapping[str, torch.Tensor], state: RecurrentState
            ) -> tuple[torch.Tensor, RecurrentState]:
        """One rollout step: raw observations (B, ...) without a time axis -> the low-noise
        action (B, 1, 7) and the next state: the LSTM state, started afresh every
        ``seq_length`` steps (``rnn_memory: reset``), or the last frames' features, over which
        the LSTM runs from a zero state (``window``)."""
        if self.ema is not None:
            return self.ema.act(obs, state)
        features = self.features({k: v[:, None] for k, v in obs.items()})
        if self.config.rnn_memory == "window":
            frames = (*state.window, features[:, 0].numpy().copy())
            out, _ = self._heads(torch.from_numpy(np.stack(frames, 1)))
            keep = frames[max(0, len(frames) - (self.config.seq_length - 1)):]
            return self.rollout_action(out)[:, -1:], RecurrentState(state.steps + 1, None, keep)
        hidden = None
        if state.hidden is not None and state.steps % self.config.seq_length != 0:
            hidden = tuple(torch.from_numpy(h) for h in state.hidden)
        out, hidden = self._heads(features, hidden)
        return self.rollout_action(out), RecurrentState(
            state.steps + 1, tuple(h.numpy().copy() for h in hidden))
