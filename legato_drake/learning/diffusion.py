"""Diffusion Policy baselines (``algo: dp_velocity``, ``dp_reltraj``): a chunk of P future
actions denoised from Gaussian noise, conditioned on the last ``obs_horizon`` observations.

As Diffusion Policy (Chi et al. 2023) does it, written for this project:

* the observation features of each of the ``obs_horizon`` steps (the LEGATO encoders per
  camera and the normalised low-dim inputs) are concatenated into one conditioning vector;
* a 1-D temporal U-Net (``ConditionalUnet1D``) predicts the noise of a (P, 7) chunk, every
  residual block modulated by FiLM (a per-channel scale and bias) of the conditioning vector
  and a sinusoidal embedding of the noise level;
* training: DDPM noise levels (``diffusers.DDPMScheduler``, squared-cosine schedule,
  ``diffusion_steps``), the L2 loss on the noise; rollout: DDIM (``diffusers.DDIMScheduler``,
  ``inference_steps``, deterministic); training optimises the weights, validation and rollout
  run an EMA of them (``ema_decay``);
* chunk actions are scaled to [-1, 1] by their per-dimension range in the training data
  (``extra_stats``, stored in the checkpoint);
* a training chunk is the expert's plan from its first step (``chunk_targets: planned``,
  ``training_chunks``): that step's action, then the motion between the poses the next
  actions aim at. In DART-noised demos the recorded actions also correct perturbations that
  have not happened yet at the chunk's start, which the network cannot know.

Two action representations (SPEC §8):

* ``dp_velocity``: LEGATO's own actions, pose deltas in the previous commanded gripper frame
  + grasp, P of them ("Diffusion Policy (Velocity)");
* ``dp_reltraj``: the P gripper poses the chunk reaches, relative to the commanded pose at the
  chunk's start (positions + rotation vectors) + grasp (UMI's relative trajectory), turned
  back into pose deltas for the diagram (``reltraj_to_deltas``).

With ``invariant_weight`` > 0 the appendix-B chunk loss is added: the DHB invariants of the
demonstrated history followed by the clean chunk the network implies at that noise level
(``x0 = (x_t - sqrt(1 - a_t) eps) / sqrt(a_t)``, differentiable, clipped to [-1, 1] as the
sampler clips it) against those of the history followed by the demonstrated chunk. With
``object_aux_weight`` > 0 (image mode) the auxiliary object loss of the LEGATO image policy
(``object_head.ObjectHead``) is added on the observation steps' image features, in training
only.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
from collections.abc import Mapping

import numpy as np
import torch
from torch import nn

from legato_drake.data.layout import IMAGE_KEYS
from legato_drake.errors import ConfigError
from legato_drake.invariants import (
    deltas_to_poses,
    history_from_observations,
    invariant_loss,
    matrix_to_quaternion,
    poses_to_deltas,
    quaternion_to_matrix,
    quaternion_to_rotation_vector,
    rotation_vector_to_quaternion,
)
from legato_drake.learning.config import LearningConfig
from legato_drake.learning.encoders import ImageEncoder, encode_sequence
from legato_drake.learning.family import PolicyFamily, Stats, masked_mean, update_average
from legato_drake.learning.normalization import Normalizer
from legato_drake.learning.object_head import ObjectHead

REPRESENTATIONS = {"dp_velocity": "velocity", "dp_reltraj": "reltraj"}
"""``algo`` -> the chunk's action representation."""
ACTION_DIM = 7
RANGE_KEY = "dp_actions"
"""The statistics key of the chunk representation's range (``min``, ``max``)."""
MIN_RANGE = 1e-4
"""A dimension whose training range is narrower is not scaled (constant dimensions)."""


# ---------------------------------------------------------------------------------------------
# action representations


def deltas_to_reltraj(actions: torch.Tensor | np.ndarray) -> torch.Tensor | np.ndarray:
    """(..., P, 7) actions (pose deltas + grasp) -> (..., P, 7) the poses they reach relative
    to the chunk's start (xyz, rotation vector) + grasp."""
    positions, rotations = deltas_to_poses(actions[..., :6])
    rotvec = quaternion_to_rotation_vector(matrix_to_quaternion(rotations[..., 1:, :, :]))
    xp = torch if isinstance(actions, torch.Tensor) else np
    return xp.concatenate([positions[..., 1:, :], rotvec, actions[..., 6:7]], -1)


def reltraj_to_deltas(reltraj: torch.Tensor | np.ndarray) -> torch.Tensor | np.ndarray:
    """Inverse of ``deltas_to_reltraj``: (..., P, 7) relative poses + grasp -> (..., P, 7)
    pose deltas (each in the previous pose's frame) + grasp."""
    xp = torch if isinstance(reltraj, torch.Tensor) else np
    rotations = quaternion_to_matrix(rotation_vector_to_quaternion(reltraj[..., 3:6]))
    eye = xp.zeros_like(rotations[..., :1, :, :]) + (
        torch.eye(3, dtype=reltraj.dtype, device=reltraj.device) if xp is torch else np.eye(3))
    positions = xp.concatenate([xp.zeros_like(reltraj[..., :1, :3]), reltraj[..., :3]], -2)
    deltas = poses_to_deltas(positions, xp.concatenate([eye, rotations], -3))
    return xp.concatenate([deltas, reltraj[..., 6:7]], -1)


def chunk_windows(actions: np.ndarray, length: int, planned: np.ndarray | None = None
                  ) -> np.ndarray:
    """Every training chunk of ``length`` steps of one demo (T, 7) -> (T, length, 7), those
    past the end padded with the last step (as the training dataset pads): with ``planned``
    (``data.derived.planned_actions``) each starts with its step's action and goes on with
    the planned ones (``chunk_targets: planned``), without it the actions alone."""
    follow = actions if planned is None else planned
    padded = np.concatenate([follow, np.repeat(follow[-1:], length - 1, 0)])
    return np.stack([np.concatenate([actions[i:i + 1], padded[i + 1:i + length]])
                     for i in range(len(actions))])


def training_chunks(batch: Mapping, start: int, length: int, targets: str) -> torch.Tensor:
    """The training chunks (B, length, 7) of a batch of windows from step ``start`` on:
    ``chunk_windows``' rule on tensors (``targets``: the config's ``chunk_targets``)."""
    actions = batch["actions"][:, start:start + length]
    if targets == "actions":
        return actions
    return torch.cat([actions[:, :1], batch["planned_actions"][:, start + 1:start + length]], 1)


# ---------------------------------------------------------------------------------------------
# the network


class SinusoidalEmbedding(nn.Module):
    """A noise level (B,) -> (B, dim) sines and cosines of geometric frequencies."""

    def __init__(self, dim: int):
        super().__init__()
        self.dim = dim

    def forward(self, t: torch.Tensor) -> torch.Tensor:
        half = self.dim // 2
        freqs = torch.exp(-math.log(10000) * torch.arange(half, device=t.device) / (half - 1))
        angles = t.float()[:, None] * freqs[None]
        return torch.cat([angles.sin(), angles.cos()], -1)


def _conv_block(c_in: int, c_out: int, kernel: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv1d(c_in, c_out, kernel, padding=kernel // 2),
                         nn.GroupNorm(8, c_out), nn.Mish())


class ConditionalResidualBlock(nn.Module):
    """Two conv blocks; the conditioning scales and shifts the first one's channels (FiLM)."""

    def __init__(self, c_in: int, c_out: int, cond_dim: int, kernel: int):
        super().__init__()
        self.first = _conv_block(c_in, c_out, kernel)
        self.second = _conv_block(c_out, c_out, kernel)
        self.film = nn.Sequential(nn.Mish(), nn.Linear(cond_dim, 2 * c_out))
        self.skip = nn.Conv1d(c_in, c_out, 1) if c_in != c_out else nn.Identity()

    def forward(self, x: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        scale, bias = self.film(cond)[..., None].chunk(2, 1)
        return self.second(self.first(x) * scale + bias) + self.skip(x)


class ConditionalUnet1D(nn.Module):
    """The noise of a chunk (B, P, A) at noise level t (B,), given a conditioning (B, C)."""

    def __init__(self, action_dim: int, cond_dim: int, dims: list[int], kernel: int,
                 step_dim: int = 64):
        super().__init__()
        self.step = nn.Sequential(SinusoidalEmbedding(step_dim), nn.Linear(step_dim, 4 * step_dim),
                                  nn.Mish(), nn.Linear(4 * step_dim, step_dim))
        cond_dim += step_dim
        widths = [action_dim, *dims]
        self.down = nn.ModuleList()
        for i, (c_in, c_out) in enumerate(zip(widths[:-1], widths[1:], strict=True)):
            last = i == len(dims) - 1
            self.down.append(nn.ModuleList([
                ConditionalResidualBlock(c_in, c_out, cond_dim, kernel),
                ConditionalResidualBlock(c_out, c_out, cond_dim, kernel),
                nn.Identity() if last else nn.Conv1d(c_out, c_out, 3, 2, 1)]))
        self.mid = nn.ModuleList([ConditionalResidualBlock(dims[-1], dims[-1], cond_dim, kernel)
                                  for _ in range(2)])
        self.up = nn.ModuleList()
        for c_out, c_in in zip(reversed(dims[:-1]), reversed(dims[1:]), strict=True):
            self.up.append(nn.ModuleList([
                ConditionalResidualBlock(2 * c_in, c_out, cond_dim, kernel),
                ConditionalResidualBlock(c_out, c_out, cond_dim, kernel),
                nn.ConvTranspose1d(c_out, c_out, 4, 2, 1)]))
        self.out = nn.Sequential(_conv_block(dims[0], dims[0], kernel),
                                 nn.Conv1d(dims[0], action_dim, 1))

    def forward(self, x: torch.Tensor, t: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        cond = torch.cat([self.step(t), cond], -1)
        h = x.transpose(1, 2)  # (B, A, P): time along the conv axis
        skips = []
        for first, second, down in self.down:
            h = second(first(h, cond), cond)
            skips.append(h)
            h = down(h)
        for block in self.mid:
            h = block(h, cond)
        for first, second, up in self.up:
            h = up(second(first(torch.cat([h, skips.pop()], 1), cond), cond))
        return self.out(h).transpose(1, 2)


# ---------------------------------------------------------------------------------------------
# the family


def _noise_generator(seed: int, count: int, scene: int | None = None) -> torch.Generator:
    """The generator of a policy's ``count``-th noise draw (a training step's, or a rollout's
    chunk): the noise depends on the config's seed, the count and (a rollout with
    ``rollout_noise: scene``) the scene's seed alone, so a resumed run or a rerun trial draws
    what an uninterrupted one did."""
    key = seed * 1_000_003 + count
    if scene is not None:
        key += (scene + 1) * 1_000_000_007
    return torch.Generator().manual_seed(key % 2**63)


@dataclasses.dataclass(frozen=True)
class DiffusionState:
    """The rollout state: the last ``obs_horizon`` observations, oldest first, how many
    chunks were sampled and the episode's scene seed (they seed each sample's initial
    noise)."""

    window: tuple[dict[str, np.ndarray], ...] = ()
    decisions: int = 0
    scene_seed: int = 0


class _Conditioner(nn.Module):
    """Observations (B, T_o, ...) -> the conditioning vector (B, T_o * F)."""

    def __init__(self, config: LearningConfig, stats: Stats, image_keys: list[str],
                 low_dim_keys: list[str]):
        super().__init__()
        self.image_keys, self.low_dim_keys = image_keys, low_dim_keys
        self.normalizers = nn.ModuleDict({k: Normalizer(stats[k]["mean"], stats[k]["std"])
                                          for k in low_dim_keys})
        self.encoders = nn.ModuleDict({
            k: ImageEncoder.from_config(config) for k in image_keys})
        self.step_dim = (sum(len(stats[k]["mean"]) for k in low_dim_keys)
                         + config.feature_dim * len(image_keys))

    def forward(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        return self.steps(obs).flatten(1)

    def steps(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """Each step's features (B, T_o, F), the image features first."""
        parts = [encode_sequence(self.encoders[k], obs[k]) for k in self.image_keys]
        parts += [self.normalizers[k](obs[k]) for k in self.low_dim_keys]
        return torch.cat(parts, -1)


class DiffusionPolicy(PolicyFamily):
    """``dp_velocity`` or ``dp_reltraj`` (the module docstring)."""

    loss_terms = ("mse", "invar", "total")

    def __init__(self, config: LearningConfig, stats: Stats):
        super().__init__(config, stats)
        os.environ.setdefault("HF_HUB_OFFLINE", "1")  # schedulers only: nothing downloads
        from diffusers import DDIMScheduler, DDPMScheduler  # heavy: only for this family

        if config.algo not in REPRESENTATIONS:
            raise ConfigError(f"algo {config.algo!r} is not a Diffusion Policy family "
                              f"({', '.join(REPRESENTATIONS)})")
        window = config.obs_horizon - 1 + config.pred_horizon
        if config.seq_length < window:
            raise ConfigError(f"seq_length must be at least obs_horizon - 1 + pred_horizon "
                              f"= {window} for {config.algo}, got {config.seq_length}")
        if config.history:
            raise ConfigError(f"history must be 0 for {config.algo} (its observation window "
                              f"is obs_horizon), got {config.history}")
        self.representation = REPRESENTATIONS[config.algo]
        self.execute_steps = config.action_horizon
        image_keys = [k for k in config.obs_keys if k in IMAGE_KEYS]
        low_dim_keys = [k for k in config.obs_keys if k not in IMAGE_KEYS]
        missing = [k for k in (*low_dim_keys, RANGE_KEY) if k not in stats]
        if missing:
            raise ValueError(f"normalisation statistics lack {', '.join(missing)}")
        low = np.asarray(stats[RANGE_KEY]["min"], np.float32).reshape(-1, ACTION_DIM)
        high = np.asarray(stats[RANGE_KEY]["max"], np.float32).reshape(-1, ACTION_DIM)
        span = high - low
        self.register_buffer("center", torch.from_numpy((high + low) / 2))
        self.register_buffer("half_range", torch.from_numpy(
            np.where(span < MIN_RANGE, 1.0, span / 2).astype(np.float32)))
        conditioner = _Conditioner(config, stats, image_keys, low_dim_keys)
        unet = ConditionalUnet1D(ACTION_DIM, conditioner.step_dim * config.obs_horizon,
                                 config.unet_dims, config.unet_kernel)
        self.net = nn.ModuleDict({"conditioner": conditioner, "unet": unet})
        self.ema = copy.deepcopy(self.net).requires_grad_(False)
        self.object_head = None
        if config.object_aux_weight > 0:
            self.object_head = ObjectHead(config.feature_dim * len(image_keys), stats)
            self.loss_terms = ("mse", "invar", "aux", "total")
        self.register_buffer("calls", torch.zeros((), dtype=torch.long))
        schedule = dict(num_train_timesteps=config.diffusion_steps,
                        beta_schedule="squaredcos_cap_v2", clip_sample=True,
                        prediction_type="epsilon")
        self.train_scheduler = DDPMScheduler(**schedule)
        self.sampler = DDIMScheduler(**schedule)

    # -- statistics and representations --------------------------------------------------

    @classmethod
    def observed_steps(cls, config: LearningConfig) -> int:
        """The ``obs_horizon`` steps a chunk is conditioned on; the rest of a training
        window holds the chunk's actions."""
        return config.obs_horizon

    @classmethod
    def extra_stats(cls, config: LearningConfig, actions: list[np.ndarray],
                    planned: list[np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
        """The range of the chunk representation: per dimension (velocity), or per chunk
        step and dimension (relative trajectory, whose range grows along the chunk)."""
        use_plan = config.chunk_targets == "planned"
        chunks = np.concatenate([
            chunk_windows(np.asarray(a, np.float64), config.pred_horizon,
                          np.asarray(p, np.float64) if use_plan else None)
            for a, p in zip(actions, planned, strict=True)])
        if REPRESENTATIONS.get(config.algo) == "reltraj":
            values = deltas_to_reltraj(chunks).reshape(len(chunks), -1)
        else:
            values = chunks.reshape(-1, ACTION_DIM)
        return {RANGE_KEY: {"min": values.min(0).astype(np.float32),
                            "max": values.max(0).astype(np.float32)}}

    def _scale(self, chunk: torch.Tensor) -> torch.Tensor:
        """Raw actions (B, P, 7) -> the representation scaled to [-1, 1]."""
        x = deltas_to_reltraj(chunk) if self.representation == "reltraj" else chunk
        return (x - self.center) / self.half_range

    def _unscale(self, x: torch.Tensor) -> torch.Tensor:
        """Inverse of ``_scale`` (the grasp left continuous)."""
        x = x * self.half_range + self.center
        return reltraj_to_deltas(x) if self.representation == "reltraj" else x

    # -- training ------------------------------------------------------------------------

    def _generator(self) -> torch.Generator:
        """Training draws its noise from (seed, call count), so a resumed run draws what an
        uninterrupted one would; validation draws the same noise every time."""
        return _noise_generator(self.config.seed, int(self.calls) if self.training else -1)

    def losses(self, batch: Mapping, levels: torch.Tensor | None = None
               ) -> dict[str, torch.Tensor]:
        """The family's losses; ``levels`` (B,) fixes each sample's noise level (diagnostics:
        ``scripts/invariant_gradients.py``), else they are drawn uniformly."""
        cfg = self.config
        net = self.net if self.training else self.ema
        To, P = cfg.obs_horizon, cfg.pred_horizon
        obs = {k: v[:, :To] for k, v in batch["obs"].items()}
        chunk = training_chunks(batch, To - 1, P, cfg.chunk_targets)
        mask = batch["pad_mask"][:, To - 1:To - 1 + P]
        x0 = self._scale(chunk)
        generator = self._generator()
        if self.training:
            self.calls += 1
        noise = torch.randn(x0.shape, generator=generator).to(x0)
        t = torch.randint(0, cfg.diffusion_steps, (len(x0),), generator=generator) \
            if levels is None else levels.to(torch.long).cpu()
        noisy = self.train_scheduler.add_noise(x0, noise, t)
        features = net["conditioner"].steps(obs)
        predicted = net["unet"](noisy, t.to(x0.device), features.flatten(1))
        mse = masked_mean(((predicted - noise) ** 2).mean(-1), mask)
        if cfg.invariant_weight > 0:
            clean = self.clean_chunk(noisy, predicted, t)
            invar = invariant_loss(self.demonstrated_history(batch),
                                   self._unscale(clean)[..., :6], chunk[..., :6],
                                   eps=cfg.invariant_eps, turn_eps=cfg.invariant_turn_eps,
                                   tail=cfg.invariant_tail, reduction="none")
            if cfg.invariant_snr_clip > 0:
                a = self.train_scheduler.alphas_cumprod.to(x0)[t]
                snr = a / (1 - a)
                invar = invar * snr.clamp(max=cfg.invariant_snr_clip) / cfg.invariant_snr_clip
            invar = invar.mean()
        else:
            invar = torch.zeros((), dtype=mse.dtype, device=mse.device)
        terms = {"mse": mse, "invar": invar}
        total = mse + cfg.invariant_weight * invar
        if self.object_head is not None:  # on the observation steps' image features
            terms["aux"] = self.object_head.loss(features, obs, batch["pad_mask"][:, :To])
            total = total + cfg.object_aux_weight * terms["aux"]
        return {**terms, "total": total}

    def clean_chunk(self, noisy: torch.Tensor, predicted: torch.Tensor, t: torch.Tensor
                    ) -> torch.Tensor:
        """The scaled clean chunk ``(x_t - sqrt(1 - a_t) eps) / sqrt(a_t)`` that the noise
        estimate ``predicted`` implies at levels ``t`` (B,), differentiable. Clipped to
        [-1, 1] as the sampler clips it (``clip_sample``): unclipped, the division by
        sqrt(a_t) ~ 5e-4 at the last level blows the estimate up, and one such sample's L_invar
        gradient outweighed the batch's L2 gradient 10 000-fold."""
        a = self.train_scheduler.alphas_cumprod.to(noisy)[t.cpu()][:, None, None]
        return ((noisy - (1 - a).sqrt() * predicted) / a.sqrt()).clamp(-1.0, 1.0)

    def demonstrated_history(self, batch: Mapping) -> torch.Tensor:
        """The demonstrated pose deltas (B, T, 6) before a training chunk: the history that
        L_invar's phi reads ahead of the chunk."""
        last = self.config.obs_horizon - 1
        return history_from_observations(batch["obs"]["delta_positions"][:, last],
                                         batch["obs"]["delta_eulers"][:, last])

    def after_step(self, step: int) -> None:
        update_average(self.ema, self.net.parameters(), self.net.buffers(), step,
                       self.config.ema_decay)

    @torch.no_grad()
    def estimate_objects(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """What the object head reads from the rollout's (EMA) image features of raw
        observations (B, T, ...): ``object_in_tcp`` (B, T, 9k) in raw units, for diagnostics
        (``scripts/chunk_fit.py``): whether the encoders the rollout runs locate the objects.
        The head itself is not averaged (it was fitted to the trained encoders, which the
        average follows closely). The policy never acts on it. Needs ``object_aux_weight``
        > 0."""
        if self.object_head is None:
            raise ValueError("this policy has no object head (object_aux_weight is 0)")
        return self.object_head.estimate(self.ema["conditioner"].steps(obs))

    def rollout_state_dict(self) -> dict[str, torch.Tensor]:
        """Without the trained weights ``net``: a rollout runs the EMA copy alone, so a
        shipped checkpoint is half the size."""
        return {k: v for k, v in self.state_dict().items() if not k.startswith("net.")}

    def load_rollout_state_dict(self, state: Mapping[str, torch.Tensor]) -> None:
        """The EMA weights, copied into ``net`` too (where a rollout never reads them)."""
        trained = {"net." + k[len("ema."):]: v for k, v in state.items()
                   if k.startswith("ema.")}
        self.load_state_dict({**state, **trained})

    # -- rollout -------------------------------------------------------------------------

    def initial_state(self, scene_seed: int = 0) -> DiffusionState:
        return DiffusionState(scene_seed=scene_seed)

    def observe(self, obs: Mapping[str, torch.Tensor], state: DiffusionState
                ) -> DiffusionState:
        step = {k: v.detach().cpu().numpy().copy() for k, v in obs.items()
                if k in self.config.obs_keys}
        window = (*state.window, step)[-self.config.obs_horizon:]
        return dataclasses.replace(state, window=window)

    @torch.no_grad()
    def act(self, obs: Mapping[str, torch.Tensor], state: DiffusionState
            ) -> tuple[torch.Tensor, DiffusionState]:
        """DDIM-denoises a chunk (B, P, 7) from the observation window (the first one
        repeated until ``obs_horizon`` are seen); the grasp is thresholded at 0.5."""
        cfg = self.config
        window = state.window or self.observe(obs, state).window
        window = (window[0],) * (cfg.obs_horizon - len(window)) + tuple(window)
        stacked = {k: torch.from_numpy(np.stack([w[k] for w in window], 1)) for k in window[0]}
        cond = self.ema["conditioner"](stacked)
        shape = (len(cond), cfg.pred_horizon, ACTION_DIM)
        if cfg.rollout_noise == "zero":
            x = torch.zeros(shape)
        else:
            seed = cfg.seed if cfg.sample_seed is None else cfg.sample_seed
            scene = state.scene_seed if cfg.rollout_noise == "scene" else None
            x = cfg.noise_scale * torch.randn(
                shape, generator=_noise_generator(seed, state.decisions, scene))
        self.sampler.set_timesteps(cfg.inference_steps)
        for t in self.sampler.timesteps:
            eps = self.ema["unet"](x, t.expand(len(x)), cond)
            x = self.sampler.step(eps, t, x).prev_sample
        chunk = self._unscale(x.clamp(-1, 1))
        chunk = torch.cat([chunk[..., :6], (chunk[..., 6:] >= 0.5).to(chunk.dtype)], -1)
        return chunk, dataclasses.replace(state, decisions=state.decisions + 1)

