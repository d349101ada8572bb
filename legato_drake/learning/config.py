"""The one configuration object of a training run, loaded from and saved to YAML.

Every checkpoint holds the whole ``LearningConfig`` it was trained with, so a checkpoint alone
rebuilds its policy. A YAML file sets any subset of the fields (the rest keep their defaults);
``overrides`` (``--set field=value`` on the command line) change single fields after loading,
e.g. ``--set invariant_weight=0`` trains the same network without L_invar (the "SE3" ablation).
"""

# No ``from __future__ import annotations``: the field checks read the real types.
import contextlib
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from legato_drake.data.layout import HISTORY, HISTORY_KEYS, IMAGE_KEYS
from legato_drake.errors import ConfigError
from legato_drake.files import atomic_write_text, read_text_file

OBS_MODES = ("image", "state")
ENCODERS = ("resnet18", "small")
PRECISIONS = ("float32", "bfloat16")
"""``encoder_precision``'s values."""
CHUNK_TARGETS = ("planned", "actions")
"""``chunk_targets``' values."""
LR_SCHEDULES = ("constant", "cosine")
"""``lr_schedule``'s values."""
RNN_MEMORIES = ("reset", "window")
"""``rnn_memory``'s values."""
GMM_ACTIONS = ("most_likely", "mixture_mean")
"""``gmm_action``'s values."""
ROLLOUT_NOISES = ("policy", "scene", "zero")
"""``rollout_noise``'s values."""
STATE_KEYS = ("tcp_commanded", "tcp_measured", "object", "object_in_tcp", "fingers")
"""Privileged observations a ``state`` policy may use: what the EpisodeRecorder records and
what ``data.derived`` computes from it."""


@dataclass
class LearningConfig:
    """A policy's architecture and how it is trained (SPEC §8)."""

    name: str = "legato"
    """Run / method name (used as the method name in evaluation tables by default)."""
    algo: str = "legato"
    """The policy family (``learning.registry``): ``legato``, a GMM over the 6 pose-delta dims
    + a 2-class grasp head; ``bc_rnn``, one GMM over all 7 action dims, grasp thresholded at
    0.5. Checked against the registry where a policy is built (a config knows no
    families)."""
    obs_mode: str = "image"
    """``image``: the two gripper images + pose-delta history (the paper's); ``state``: the
    privileged state features ``state_keys`` + pose-delta history (fast, for CPU)."""
    state_keys: list[str] = field(default_factory=lambda: ["object_in_tcp", "fingers"])
    """Privileged observations of the ``state`` mode (``STATE_KEYS``)."""
    history: int = 2
    """Pose-delta history steps the network sees (0, 1 or 2; datasets hold 2, oldest first).
    The paper feeds 2. In our measurements the history is a shortcut that breaks the closed
    loop (the copycat problem: in the data a stop shows in the history a step after it
    happens, so the history predicts the release; at rollout the policy's own history never
    shows it), so the small configs use 0. L_invar reads the demonstrated history from the
    dataset whatever this is."""
    history_noise: float = 0.0
    """Training only: Gaussian noise (in normalised units) added to the history inputs, a
    remedy for the copycat effect when ``history`` > 0."""
    history_dropout: float = 0.0
    """Training only: probability that a sequence's history inputs are zeroed (their
    normalised mean), a remedy for the copycat effect when ``history`` > 0."""
    encoder: str = "resnet18"
    """Image trunk: ``resnet18`` (the paper's, not pretrained, 1 channel) or ``small``."""
    encoder_channels: list[int] = field(default_factory=lambda: [16, 32, 32])
    """Channels of the ``small`` trunk's 3x3 conv layers."""
    encoder_strides: list[int] | None = None
    """Strides (1 or 2) of the ``small`` trunk's layers, one per ``encoder_channels`` entry;
    None: 2 each. A stride-1 layer keeps its input's resolution, so the keypoints' maps stay
    finer (84² with strides 2, 2, 1 gives 21², not 11²)."""
    keypoints: int = 32
    """Spatial-softmax keypoints per camera."""
    feature_dim: int = 64
    """Per-camera feature size after the keypoints' linear layer."""
    image_resize: int = 0
    """Square size the camera images are scaled to (area averaging) before the crop, in
    training and at rollout alike; 0 keeps their 128 x 128."""
    image_crop: int = 0
    """Square crop of the camera images before the encoder (after ``image_resize``): a random
    one per image in training, the centre one at rollout (robomimic's crop randomizer); 0
    keeps them whole. The crop's play (resized size minus crop) is how far, in pixels, the
    training images shift: what the policy learns not to see."""
    object_aux_weight: float = 0.0
    """Image mode, every family: the weight of an auxiliary loss, in training only, that
    regresses the objects' poses in the gripper's frame (``object_in_tcp``, normalised) from
    the image features by a linear head, so the encoder must find the objects in its views;
    0: none. The policy still sees only its images at rollout. A remedy to measure for an
    image policy that barely answers a shifted view (``scripts/legato_fit.py --shifts``)."""
    encoder_precision: str = "float32"
    """``float32`` or ``bfloat16`` (autocast of the image trunk: about 2x faster on CPUs with
    AVX-512 BF16 and on GPUs; slow where the CPU lacks it)."""
    rnn_layers: int = 3
    rnn_hidden: int = 400
    mlp_dims: list[int] = field(default_factory=lambda: [2048, 2048, 2048])
    gmm_modes: int = 5
    min_std: float = 1e-4
    """Added to the softplus of the GMM scales."""
    seq_length: int = 20
    """Training sequence length: what the LSTM is trained to remember (``rnn_memory``)."""
    rnn_memory: str = "reset"
    """How a recurrent policy remembers at rollout. ``reset``: the LSTM state starts afresh
    every ``seq_length`` steps (robomimic's), so right after each reset the policy acts on
    one frame; ``window``: every step reruns the LSTM from a zero state over the last
    ``seq_length`` frames' features (each frame encoded once), so it always acts on
    ``seq_length - 1`` steps of context, as the last step of a training sequence does."""
    gmm_action: str = "most_likely"
    """Which point of a recurrent policy's GMM it acts on at rollout. ``most_likely``: the mean
    of the most likely component (deterministic; a policy whose weight is split between nearby
    components hops between their means from step to step); ``mixture_mean``: the mixture's
    mean, the components' means weighted by their probabilities (smooth across such splits,
    but between two distinct modes it averages them). Training is the same either way."""
    batch_size: int = 16
    lr: float = 1e-4
    lr_schedule: str = "constant"
    """``constant``: ``lr`` throughout; ``cosine``: from ``lr`` down to 0 at ``steps`` along a
    half cosine, so that the last snapshots are the settled end of training rather than a
    draw from the noise of constant-rate steps (``learning.train.learning_rate``)."""
    weight_decay: float = 0.0
    grad_clip: float = 0.0
    """Clip the gradient norm to this (0: no clipping)."""
    steps: int = 1_200_000
    """Optimizer steps in all (the paper: 6000 epochs x 200 steps)."""
    nll_weight: float = 1.0
    grasp_weight: float = 0.2
    invariant_weight: float = 0.001
    """Weight of L_invar; 0 trains without it (the paper's "LEGATO (SE3)" / plain BC-RNN).
    The paper's 0.005 multiplies the reference's loss, a mean over the 5 values of each block;
    ours sums the 10 values of a row, 5 times as much, so 0.001 is the paper's weight."""
    invariant_eps: float = 1e-6
    """Motion resolution of L_invar (m and rad per step, ``invariants`` ``eps``): motion
    below it counts as rest. The invariants' gradients scale like 1 / max(|action|, eps), so
    a tiny eps lets the nearly still steps at the ends of moves dominate the loss."""
    invariant_turn_eps: float = 1e-6
    """Turn resolution of L_invar (the sine of the angle between consecutive segments,
    ``invariants`` ``turn_eps``): a smaller turn keeps the previous binormal. Straight moves
    have no plane of their own, so at 1e-6 the th2 values of a straight move follow the
    rounding of its deltas."""
    invariant_snr_clip: float = 0.0
    """Diffusion Policy: weigh each sample's L_invar by ``min(SNR_t, clip) / clip`` (Min-SNR
    weighting; ``SNR_t = a_t / (1 - a_t)``), so the noisy levels, whose implied clean chunk is
    centimetres off, weigh little; 0 weighs every level alike."""
    invariant_tail: bool = False
    """Compare the window's tail too (``invariants.invariant_loss``): without it (the
    appendix's loss) a single predicted action enters L_invar through th2 alone."""
    obs_horizon: int = 2
    """Diffusion Policy: observation steps the network is conditioned on (the current one
    and those before it)."""
    pred_horizon: int = 16
    """Diffusion Policy: actions predicted per decision (P); ``seq_length`` must be at least
    ``obs_horizon - 1 + pred_horizon`` (a training window holds both)."""
    action_horizon: int = 8
    """Diffusion Policy: actions of each prediction executed before the next (k <= P)."""
    chunk_targets: str = "planned"
    """Diffusion Policy: what a training chunk of P actions from step t is. ``planned``: the
    step's action, then the motion between the poses the next actions aim at
    (``data.derived.planned_actions``: the expert's plan from where it is); ``actions``: the
    recorded actions themselves, which in DART-noised demos correct perturbations still to
    come, so their composition drifts from the plan (14 mm after 8 steps on the lid demos)."""
    unet_dims: list[int] = field(default_factory=lambda: [64, 128, 256])
    """Diffusion Policy: channels of the temporal U-Net's levels (each halves the time axis
    but the last)."""
    unet_kernel: int = 5
    """Diffusion Policy: the U-Net's temporal convolution width."""
    diffusion_steps: int = 100
    """Diffusion Policy: DDPM noise levels in training (squared-cosine schedule)."""
    inference_steps: int = 10
    """Diffusion Policy: DDIM denoising steps per decision at rollout."""
    sample_seed: int | None = None
    """Diffusion Policy: seeds the initial noise of each rollout decision's chunk (None:
    ``seed``, the training's); changing it alone tells how much a policy's success owes to
    its noise draws."""
    rollout_noise: str = "policy"
    """Diffusion Policy: what else the initial noise of a rollout's k-th chunk depends on.
    ``policy``: nothing, so the k-th decision of every trial starts from the same noise and
    a policy's trials share one draw of it; ``scene``: the episode's scene seed too, so
    trials draw their noise independently (and a rerun of a scene draws the same); ``zero``:
    no noise, every chunk denoised from zeros (DDIM is then a deterministic function of the
    observations)."""
    noise_scale: float = 1.0
    """Diffusion Policy: the initial noise of each rollout chunk, drawn as ``rollout_noise``
    says, is multiplied by it: a sampling temperature between 1 (draws from what the network
    learnt) and 0 (the same as ``rollout_noise: zero``)."""
    ema: bool = False
    """LEGATO and BC-RNN: also keep an exponential moving average of the weights (decay
    ``ema_decay``) and validate, select and roll out the average; a training checkpoint keeps
    the trained weights beside it, a snapshot or shipped one the average alone. Diffusion
    Policy always averages."""
    ema_decay: float = 0.999
    """The most a step keeps of the weights' moving average (warmed up as
    ``(1 + step) / (10 + step)``); rollout and validation use the average. Diffusion Policy
    always averages, the recurrent families with ``ema``."""
    valid_every: int = 200
    """Steps between validation losses (and ``best.pt`` updates)."""
    valid_batches: int = 8
    checkpoint_every: int = 200
    """Steps between ``last.pt`` writes (also written at the end)."""
    snapshot_every: int = 0
    """Steps between kept snapshots ``step_<N>.pt`` (0: none), the candidates that
    ``legato-drake select`` rolls out on validation scene seeds."""
    seed: int = 0
    """Seeds the initial weights, every random draw of a training (crops, noise, dropout)
    and, unless ``batch_seed`` is set, the batch order."""
    batch_seed: int | None = None
    """Seeds the batch order alone (which demo windows each step draws; None: ``seed``), so
    that trainings can share their initial weights and differ in their batches, or the
    reverse. Every other random number of a training (initial weights, crops, noise, dropout)
    stays ``seed``'s."""
    num_workers: int = 0
    """DataLoader worker processes."""
    cpu_threads: int = 1
    """torch threads when training on the CPU (0: torch's default). One is fastest for the
    small networks on a shared 2-core machine."""
    cache_images: bool = False
    """Hold all images in memory (fast, about 33 kB per sample)."""

    def validate(self, where: str = "") -> "LearningConfig":
        """Checks every field; raises ConfigError naming the field (and ``where``)."""
        place = f" in {where}" if where else ""

        def bad(name: str, message: str) -> ConfigError:
            return ConfigError(f"{name}{place} {message}")

        for name, allowed in (("obs_mode", OBS_MODES), ("encoder", ENCODERS)):
            if getattr(self, name) not in allowed:
                raise bad(name, f"must be one of {', '.join(allowed)}; got "
                                f"{getattr(self, name)!r}")
        unknown = [k for k in self.state_keys if k not in STATE_KEYS]
        if unknown or (self.obs_mode == "state" and not self.state_keys):
            raise bad("state_keys", f"must be a non-empty list of {', '.join(STATE_KEYS)}; got "
                                    f"{self.state_keys!r}")
        for name in ("keypoints", "feature_dim", "rnn_layers", "rnn_hidden", "gmm_modes",
                     "seq_length", "batch_size", "steps", "valid_every", "valid_batches",
                     "checkpoint_every", "obs_horizon", "pred_horizon", "action_horizon",
                     "unet_kernel", "diffusion_steps", "inference_steps"):
            if getattr(self, name) < 1:
                raise bad(name, f"must be a positive integer, got {getattr(self, name)}")
        for name, allowed in (("encoder_precision", PRECISIONS),
                              ("chunk_targets", CHUNK_TARGETS)):
            if getattr(self, name) not in allowed:
                raise bad(name, f"must be one of {', '.join(allowed)}; got "
                                f"{getattr(self, name)!r}")
        if self.image_resize != 0 and not 8 <= self.image_resize <= 128:
            raise bad("image_resize", f"must be 0 (no resize) or 8-128 pixels, got "
                                      f"{self.image_resize}")
        if self.image_crop != 0 and not 8 <= self.image_crop <= 128:
            raise bad("image_crop", f"must be 0 (no crop) or 8-128 pixels, got "
                                    f"{self.image_crop}")
        if self.image_resize and self.image_crop > self.image_resize:
            raise bad("image_crop", f"must be at most image_resize ({self.image_resize}), got "
                                    f"{self.image_crop}")
        if any(c < 1 for c in self.encoder_channels) or not self.encoder_channels:
            raise bad("encoder_channels", f"must be positive integers, got "
                                          f"{self.encoder_channels}")
        if self.encoder_strides is not None and (
                len(self.encoder_strides) != len(self.encoder_channels)
                or any(s not in (1, 2) for s in self.encoder_strides)):
            raise bad("encoder_strides", f"must be one stride, 1 or 2, per encoder_channels "
                                         f"entry ({len(self.encoder_channels)}), got "
                                         f"{self.encoder_strides}")
        if any(d < 1 for d in self.mlp_dims):
            raise bad("mlp_dims", f"must be positive integers, got {self.mlp_dims}")
        if not self.unet_dims or any(d < 1 or d % 8 for d in self.unet_dims):
            raise bad("unet_dims", f"must be multiples of 8 (group norm), got {self.unet_dims}")
        if self.action_horizon > self.pred_horizon:
            raise bad("action_horizon", f"must be at most pred_horizon ({self.pred_horizon}), "
                                        f"got {self.action_horizon}")
        if self.inference_steps > self.diffusion_steps:
            raise bad("inference_steps", f"must be at most diffusion_steps "
                                         f"({self.diffusion_steps}), got {self.inference_steps}")
        if self.rnn_memory not in RNN_MEMORIES:
            raise bad("rnn_memory", f"must be one of {', '.join(RNN_MEMORIES)}, got "
                                    f"{self.rnn_memory!r}")
        if self.rollout_noise not in ROLLOUT_NOISES:
            raise bad("rollout_noise", f"must be one of {', '.join(ROLLOUT_NOISES)}, got "
                                       f"{self.rollout_noise!r}")
        if not 0.0 <= self.noise_scale <= 1.0:  # NaN too
            raise bad("noise_scale", f"must be in [0, 1], got {self.noise_scale!r}")
        if self.gmm_action not in GMM_ACTIONS:
            raise bad("gmm_action", f"must be one of {', '.join(GMM_ACTIONS)}, got "
                                    f"{self.gmm_action!r}")
        if self.lr_schedule not in LR_SCHEDULES:
            raise bad("lr_schedule", f"must be one of {', '.join(LR_SCHEDULES)}, got "
                                     f"{self.lr_schedule!r}")
        if self.ema and self.algo not in ("legato", "bc_rnn"):
            raise bad("ema", f"is for legato and bc_rnn ({self.algo} always averages its "
                             f"weights), got true")
        if not (math.isfinite(self.ema_decay) and 0 <= self.ema_decay < 1):
            raise bad("ema_decay", f"must be in [0, 1), got {self.ema_decay}")
        for name in ("lr", "min_std", "invariant_eps", "invariant_turn_eps"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise bad(name, f"must be a positive number, got {getattr(self, name)}")
        for name in ("weight_decay", "grad_clip", "nll_weight", "grasp_weight",
                     "invariant_weight", "invariant_snr_clip", "object_aux_weight"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise bad(name, f"must be a non-negative number, got {getattr(self, name)}")
        if self.object_aux_weight > 0 and self.obs_mode != "image":
            raise bad("object_aux_weight", f"needs obs_mode image (got {self.obs_mode}); 0 "
                                           f"turns it off")
        if self.history not in range(HISTORY + 1):
            raise bad("history", f"must be 0, 1 or {HISTORY} (pose-delta steps), got "
                                 f"{self.history!r}")
        if not (math.isfinite(self.history_noise) and self.history_noise >= 0):
            raise bad("history_noise", f"must be a non-negative number, got "
                                       f"{self.history_noise}")
        if not (math.isfinite(self.history_dropout) and 0 <= self.history_dropout <= 1):
            raise bad("history_dropout", f"must be in [0, 1], got {self.history_dropout}")
        for name in ("num_workers", "seed", "cpu_threads", "snapshot_every", "batch_seed"):
            if (getattr(self, name) or 0) < 0:
                raise bad(name, f"must be a non-negative integer, got {getattr(self, name)}")
        return self

    @property
    def batch_order_seed(self) -> int:
        """The seed of the training's batch order: ``batch_seed``, or ``seed`` without it."""
        return self.seed if self.batch_seed is None else self.batch_seed

    @property
    def obs_keys(self) -> tuple[str, ...]:
        """The dataset observations the network reads, in a fixed order (the pose-delta
        history only with ``history`` > 0)."""
        history = HISTORY_KEYS if self.history > 0 else ()
        if self.obs_mode == "image":
            return (*IMAGE_KEYS, *history)
        return (*history, *self.state_keys)

    @property
    def dataset_keys(self) -> tuple[str, ...]:
        """The observations training reads: the network's, plus the demonstrated pose-delta
        history that L_invar needs (appendix A) even when the network does not see it, and
        ``object_in_tcp`` for the auxiliary object loss (``object_aux_weight``)."""
        aux = ("object_in_tcp",) if self.object_aux_weight > 0 else ()
        return (*self.obs_keys, *(k for k in HISTORY_KEYS if k not in self.obs_keys), *aux)

    def to_dict(self) -> dict:
        """A plain dict (for checkpoints and YAML)."""
        return dataclasses.asdict(self)


NEUTRAL_VALUES = {
    "invariant_turn_eps": lambda fields: fields["invariant_turn_eps"] == fields["invariant_eps"],
    "invariant_snr_clip": lambda fields: fields["invariant_snr_clip"] == 0,
    "image_resize": lambda fields: fields["image_resize"] == 0,
    "object_aux_weight": lambda fields: fields["object_aux_weight"] == 0,
    "lr_schedule": lambda fields: fields["lr_schedule"] == "constant",
    "rnn_memory": lambda fields: fields["rnn_memory"] == "reset",
    "gmm_action": lambda fields: fields["gmm_action"] == "most_likely",
    "ema": lambda fields: not fields["ema"],
    "batch_seed": lambda fields: fields["batch_seed"] in (None, fields["seed"]),
    "sample_seed": lambda fields: fields["sample_seed"] in (None, fields["seed"]),
    "rollout_noise": lambda fields: fields["rollout_noise"] == "policy",
    "noise_scale": lambda fields: fields["noise_scale"] == 1.0,
    "encoder_strides": lambda fields: fields["encoder_strides"] is None or all(
        s == 2 for s in fields["encoder_strides"]),
}
"""Fields added after experiments had keyed their results on whole configs, each with a test
for the values at which it does what the code did before it existed (L_invar's turn
resolution was its motion resolution; every noise level weighed alike; images kept at 128 x
128; no auxiliary object loss; a constant learning rate; the LSTM reset at rollout and acting
on its GMM's most likely component; no weight average for the recurrent families; the batch
order seeded by ``seed``, which a ``batch_seed`` equal to it also does, and so the rollout
noise, drawn alike in every trial and at full scale; every small-trunk layer at stride
2). At those values ``key_fields`` leaves the field out, so those results keep their keys."""


def key_fields(config: LearningConfig | dict) -> dict:
    """The fields that name what ``config`` (or a config's ``to_dict``) trains in an
    experiment's unit keys: all of them, but the ``NEUTRAL_VALUES`` fields at a neutral
    value."""
    fields = config if isinstance(config, dict) else config.to_dict()
    return {k: v for k, v in fields.items()
            if not (k in NEUTRAL_VALUES and NEUTRAL_VALUES[k](fields))}


ROLLOUT_FIELDS = ("action_horizon", "inference_steps", "sample_seed", "rollout_noise",
                  "noise_scale", "rnn_memory", "gmm_action")
"""Fields that change how a trained network acts, never how it is trained (a Diffusion
Policy's executed steps per chunk, DDIM steps and rollout noise, a recurrent policy's memory
and the point of its GMM it acts on): an experiment trains once for configs that differ only
in these, and writes each one's values into its copies of the checkpoints."""


_FIELDS = {f.name: f for f in dataclasses.fields(LearningConfig)}


def _coerce(name: str, value: object, where: str) -> object:
    """Checks one raw YAML value against the field's type; returns it in that type."""
    kind = _FIELDS[name].type
    place = f" in {where}" if where else ""
    if kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{name}{place} must be true or false, got {value!r}")
    elif kind is int or kind == int | None:
        optional = kind is not int
        if (value is None and not optional) or isinstance(value, bool) \
                or not isinstance(value, int | None):
            raise ConfigError(f"{name}{place} must be an integer{' or null' * optional}, got "
                              f"{value!r}")
    elif kind is float:
        if isinstance(value, str):  # YAML 1.1 reads 1e-4 (no dot) as a string
            with contextlib.suppress(ValueError):
                value = float(value)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{name}{place} must be a number, got {value!r}")
        value = float(value)
    elif kind is str:
        if not isinstance(value, str):
            raise ConfigError(f"{name}{place} must be a string, got {value!r}")
    else:  # list[int], list[int] | None or list[str]
        optional = kind == list[int] | None
        if optional and value is None:
            return None
        item = str if kind == list[str] else int
        if not isinstance(value, list) or not all(
                isinstance(v, item) and not isinstance(v, bool) for v in value):
            raise ConfigError(f"{name}{place} must be a list of {item.__name__}"
                              f"{' or null' * optional}, got {value!r}")
        value = list(value)
    return value


def config_from_dict(raw: object, where: str = "") -> LearningConfig:
    """Builds a validated config from a mapping of fields; an unknown field is an error
    naming it, ``where`` (the file) and the valid fields."""
    place = f" in {where}" if where else ""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ConfigError(f"the learning config{place} must be a mapping of fields, got "
                          f"{raw!r}")
    for key in raw:
        if key not in _FIELDS:
            raise ConfigError(f"unknown field {key!r}{place}; valid fields: "
                              f"{', '.join(_FIELDS)}")
    values = {k: _coerce(k, v, where) for k, v in raw.items()}
    return LearningConfig(**values).validate(where)


def _parse_value(text: str) -> object:
    try:
        return yaml.safe_load(f"value: {text}")["value"]
    except Exception:  # noqa: BLE001 - any YAML problem: keep the text as a string
        return text


def apply_overrides(config: LearningConfig, overrides: list[str] | None,
                    where: str = "--set") -> LearningConfig:
    """``["invariant_weight=0", "steps=500"]`` -> a copy with those fields set (YAML values)."""
    raw = config.to_dict()
    for item in overrides or []:
        if "=" not in item:
            raise ConfigError(f"{where} {item!r}: expected FIELD=VALUE")
        key, text = item.split("=", 1)
        raw[key.strip()] = _parse_value(text.strip())
    return config_from_dict(raw, where)


def apply_rollout_overrides(config: LearningConfig, overrides: list[str] | None,
                            where: str = "--set") -> LearningConfig:
    """``apply_overrides`` for a trained policy: only its ``ROLLOUT_FIELDS`` may change."""
    for item in overrides or []:
        name = item.split("=", 1)[0].strip()
        if name not in ROLLOUT_FIELDS:
            raise ConfigError(f"{where} {item!r}: a trained policy can change only how it "
                              f"acts: {', '.join(ROLLOUT_FIELDS)}")
    return apply_overrides(config, overrides, where)


def load_config(path: str | Path, overrides: list[str] | None = None) -> LearningConfig:
    """Loads a learning config YAML file (errors name the file and the field)."""
    text = read_text_file(path, "learning config file")
    try:
        raw = yaml.safe_load(text) if text.strip() else {}
    except Exception as e:  # noqa: BLE001 - the YAML parser's many error types
        raise ConfigError(f"malformed learning config {path}: {e}") from None
    return apply_overrides(config_from_dict(raw, str(path)), overrides)


def save_config(config: LearningConfig, path: str | Path) -> None:
    """Writes ``config`` as YAML (atomically)."""
    atomic_write_text(Path(path), yaml.safe_dump(config.to_dict(), default_flow_style=None))
