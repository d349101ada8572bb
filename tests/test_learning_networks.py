"""Encoders, spatial softmax, GMM heads, the loss terms and normalisation."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F  # noqa: N812

from legato_drake.data.derived import observation_sizes
from legato_drake.data.torch_dataset import DemoSequenceDataset, image_to_tensor
from legato_drake.errors import ConfigError
from legato_drake.learning.encoders import (
    ImageEncoder,
    SpatialSoftmax,
    crop_images,
    resize_images,
)
from legato_drake.learning.normalization import OBS_MIN_STD, Normalizer, compute_stats
from legato_drake.learning.policies import PolicyOutput, RecurrentGMMPolicy
from tests.learning_helpers import synthetic_dataset, tiny_config

B, T = 3, 5


def _stats(state: bool = True) -> dict:
    rng = np.random.default_rng(0)
    dims = observation_sizes(3)
    return {k: compute_stats([rng.normal(0, 0.01, (50, d))]) for k, d in dims.items()}


def _batch(image: int = 0) -> dict:
    g = torch.Generator().manual_seed(0)
    obs = {"delta_positions": 0.01 * torch.randn(B, T, 6, generator=g),
           "delta_eulers": 0.01 * torch.randn(B, T, 6, generator=g),
           "tcp_commanded": torch.randn(B, T, 7, generator=g),
           "object": torch.randn(B, T, 21, generator=g),
           "object_in_tcp": torch.randn(B, T, 27, generator=g), "fingers": torch.rand(B, T, 2)}
    if image:
        obs["left_gray"] = torch.rand(B, T, 1, image, image, generator=g)
        obs["right_gray"] = torch.rand(B, T, 1, image, image, generator=g)
    actions = 0.01 * torch.randn(B, T, 7, generator=g)
    actions[..., 6] = (torch.arange(T) >= 2).float()
    mask = torch.ones(B, T, dtype=torch.bool)
    mask[0, -1] = False
    return {"obs": obs, "actions": actions, "pad_mask": mask}


@pytest.mark.parametrize("trunk,size,channels", [("small", 32, [4, 8]),
                                                 ("resnet18", 64, None)])
def test_image_encoder_shape(trunk, size, channels):
    encoder = ImageEncoder(trunk, keypoints=32, feature_dim=64, channels=channels)
    assert encoder(torch.rand(2, 1, size, size)).shape == (2, 64)


def test_small_trunk_strides_set_the_keypoint_maps_resolution():
    """``encoder_strides``: a stride-1 layer keeps its input's resolution (84² through 2, 2, 1
    gives 21² maps, through the default 2, 2, 2 11²)."""
    images = torch.rand(2, 1, 84, 84)
    for strides, size in ((None, 11), ([2, 2, 2], 11), ([2, 2, 1], 21), ([2, 1, 1], 42)):
        encoder = ImageEncoder("small", 8, 16, [4, 8, 8], strides=strides)
        assert encoder.trunk(images).shape == (2, 8, size, size)
        assert encoder(images).shape == (2, 16)


def test_crops_are_windows_of_the_image_random_in_training_centred_at_rollout():
    """``crop_images`` is the one crop of training (random) and rollout (centred)."""
    images = torch.arange(3 * 2 * 10 * 12, dtype=torch.float32).reshape(3, 2, 10, 12)
    centre = crop_images(images, 6, random=False)
    torch.testing.assert_close(centre, images[:, :, 2:8, 3:9])
    torch.manual_seed(0)
    crops = crop_images(images, 6, random=True)
    assert crops.shape == (3, 2, 6, 6)
    offsets = set()
    for n in range(3):
        top, left = divmod(int(crops[n, 0, 0, 0] - images[n, 0, 0, 0]), 12)
        torch.testing.assert_close(crops[n], images[n, :, top:top + 6, left:left + 6])
        offsets.add((top, left))
    assert len(offsets) > 1  # each image its own offset
    torch.manual_seed(0)
    torch.testing.assert_close(crop_images(images, 6, random=True), crops)  # seeded
    with pytest.raises(ValueError, match="image_crop 16"):
        crop_images(images, 16, random=False)


@pytest.mark.parametrize("precision", ["float32", "bfloat16"])
def test_the_encoder_crops_in_training_not_at_rollout(precision):
    """With ``crop``, eval mode is deterministic (the centre crop) and equals encoding the
    centre crop without ``crop``; train mode varies with the random crop. bfloat16 changes
    the numbers a little, not the output's type or shape."""
    torch.manual_seed(0)
    encoder = ImageEncoder("small", keypoints=8, feature_dim=16, channels=[4, 8], crop=24,
                           precision=precision)
    images = torch.rand(4, 1, 32, 32)
    encoder.eval()
    out = encoder(images)
    assert out.dtype == torch.float32 and out.shape == (4, 16)
    torch.testing.assert_close(encoder(images), out)
    encoder.crop = 0
    torch.testing.assert_close(encoder(images[:, :, 4:28, 4:28]), out)
    encoder.crop = 24
    encoder.train()
    assert not torch.allclose(encoder(images), out)
    if precision == "bfloat16":
        full = ImageEncoder("small", keypoints=8, feature_dim=16, channels=[4, 8], crop=24)
        full.load_state_dict(encoder.state_dict())
        full.eval(), encoder.eval()
        difference = (full(images) - encoder(images)).abs().max()
        assert 0 < difference < 0.1


def test_resize_keeps_the_whole_view_and_the_encoder_resizes_before_it_crops():
    """``image_resize`` scales the whole view (area averaging: a 2x2 block becomes its mean),
    in training and at rollout alike; the crop then cuts the resized image, so its play is
    the resized size minus the crop (here 2 px), not 128 minus the crop."""
    images = torch.arange(16, dtype=torch.float32).reshape(1, 1, 4, 4)
    torch.testing.assert_close(resize_images(images, 2),
                               torch.tensor([[[[2.5, 4.5], [10.5, 12.5]]]]))
    assert resize_images(images, 4) is images
    torch.manual_seed(0)
    encoder = ImageEncoder("small", keypoints=8, feature_dim=16, channels=[4, 8], crop=24,
                           resize=26)
    frames = torch.rand(4, 1, 32, 32)
    encoder.eval()
    out = encoder(frames)
    encoder.resize, encoder.crop = 0, 0
    torch.testing.assert_close(encoder(resize_images(frames, 26)[:, :, 1:25, 1:25]), out)
    encoder.resize, encoder.crop = 26, 24
    encoder.train()  # a training crop is a random window of the resized image
    torch.manual_seed(1)
    crops = crop_images(resize_images(frames, 26), 24, random=True)
    torch.manual_seed(1)
    trained = encoder(frames)
    encoder.resize, encoder.crop = 0, 0
    torch.testing.assert_close(encoder(crops), trained)


def test_small_trunk_keypoints_tell_images_apart_at_initialisation():
    """The small trunk's keypoints must move with the image from the first step on: without
    its normalisation they were the same to 2e-4 for every image, and the image policy
    learned no grasp (issue 17). Images: a bright square at eight places on a dark field."""
    torch.manual_seed(0)
    images = torch.full((8, 1, 84, 84), 0.1)
    for i in range(8):
        top, left = 8 * i, 60 - 7 * i
        images[i, :, top:top + 16, left:left + 16] = 0.9
    encoder = ImageEncoder("small", 32, 64, [16, 32, 32]).eval()
    with torch.no_grad():
        keypoints = encoder.keypoints(encoder.trunk(images))
    assert keypoints.std(0).mean() > 5e-3


def test_spatial_softmax_keypoints_in_range_and_at_a_known_peak():
    softmax = SpatialSoftmax(8, 5)
    points = softmax(torch.randn(2, 8, 9, 11))
    assert points.shape == (2, 5, 2) and points.abs().max() <= 1.0
    maps = torch.full((1, 2, 5, 9), -1e4)
    maps[0, 0, 0, 8] = 0.0   # top-right corner: x = 1, y = -1
    maps[0, 1, 2, 4] = 0.0   # centre
    xy = SpatialSoftmax.expected_xy(maps)[0]
    torch.testing.assert_close(xy, torch.tensor([[1.0, -1.0], [0.0, 0.0]]))

def test_keypoint_attention_is_what_the_encoder_reads_its_keypoints_from():
    """``keypoint_attention`` (legato_fit's diagnostic) is the encoder's own softmax: each
    keypoint's weights sum to 1, and their expected coordinates are the keypoints."""
    torch.manual_seed(0)
    encoder = ImageEncoder("small", 6, 8, [8, 8], resize=32).eval()
    images = torch.rand(3, 1, 64, 64)
    with torch.no_grad():
        attention = encoder.keypoint_attention(images)
        features = encoder.trunk_features(images)
        keypoints = encoder.keypoints(features)
    side = features.shape[-1]
    assert attention.shape == (3, 6, side * side)
    torch.testing.assert_close(attention.sum(-1), torch.ones(3, 6))
    coords = torch.linspace(-1.0, 1.0, side)
    grid = attention.reshape(3, 6, side, side)
    torch.testing.assert_close((grid.sum(-2) * coords).sum(-1), keypoints[..., 0])
    torch.testing.assert_close((grid.sum(-1) * coords).sum(-1), keypoints[..., 1])



@pytest.mark.parametrize("algo", ["legato", "bc_rnn"])
@pytest.mark.parametrize("mode", ["state", "image"])
def test_policy_shapes_and_finite_log_prob(algo, mode):
    config = tiny_config(algo=algo, obs_mode=mode, gmm_modes=5)
    policy = RecurrentGMMPolicy(config, _stats())
    batch = _batch(image=16 if mode == "image" else 0)
    out, (h, c) = policy(batch["obs"])
    dims = 6 if algo == "legato" else 7
    assert out.logits.shape == (B, T, 5)
    assert out.means.shape == out.scales.shape == (B, T, 5, dims)
    assert (out.scales >= config.min_std).all()
    assert h.shape == c.shape == (1, B, 16)
    assert (out.grasp_logits is None) == (algo == "bc_rnn")
    if algo == "legato":
        assert out.grasp_logits.shape == (B, T, 2)
    log_prob = out.distribution().log_prob(torch.zeros(B, T, dims))
    assert log_prob.shape == (B, T) and torch.isfinite(log_prob).all()
    action, state = policy.act({k: v[:, 0] for k, v in batch["obs"].items()},
                               policy.initial_state())
    assert action.shape == (B, 1, 7) and set(action[:, 0, 6].tolist()) <= {0.0, 1.0}
    assert state.steps == 1 and state.hidden[0].shape == (1, B, 16)
    losses = policy.losses(batch)
    assert set(losses) == {"nll", "ce", "invar", "total"}
    assert all(torch.isfinite(v) for v in losses.values())


def test_mode_action_takes_the_most_likely_component_in_raw_units():
    policy = RecurrentGMMPolicy(tiny_config(), _stats())
    logits = torch.tensor([[[0.0, 3.0, 1.0]]])
    means = torch.arange(18, dtype=torch.float32).reshape(1, 1, 3, 6)
    grasp = torch.tensor([[[0.2, 1.5]]])
    out = PolicyOutput(logits, means, torch.ones_like(means), grasp)
    action = policy.mode_action(out)[0, 0]
    norm = policy.normalizers["actions"]
    torch.testing.assert_close(action[:6], means[0, 0, 1] * norm.std[:6] + norm.mean[:6])
    assert action[6] == 1.0


def test_grasp_loss_is_cross_entropy_on_logits():
    config = tiny_config(invariant_weight=0.0)
    policy = RecurrentGMMPolicy(config, _stats())
    batch = _batch()
    batch["pad_mask"][:] = True
    out, _ = policy(batch["obs"])
    expected = F.cross_entropy(out.grasp_logits.reshape(-1, 2),
                               batch["actions"][..., 6].reshape(-1).long())
    torch.testing.assert_close(policy.losses(batch)["ce"], expected)
    double = F.cross_entropy(torch.softmax(out.grasp_logits, -1).reshape(-1, 2),
                             batch["actions"][..., 6].reshape(-1).long())
    assert not torch.isclose(expected, double)


@pytest.mark.parametrize("mode", ["state", "image"])
def test_invariant_loss_gradient_reaches_the_encoder_and_lstm(mode):
    torch.manual_seed(0)
    config = tiny_config(obs_mode=mode, invariant_weight=1.0)
    policy = RecurrentGMMPolicy(config, _stats())
    batch = _batch(image=16 if mode == "image" else 0)
    invar = policy.losses(batch)["invar"]
    assert invar > 0
    invar.backward()
    assert policy.rnn.weight_ih_l0.grad.abs().sum() > 0
    assert policy.means_head.weight.grad.abs().sum() > 0
    if mode == "image":
        assert policy.encoders["left_gray"].trunk[0].weight.grad.abs().sum() > 0
    without = RecurrentGMMPolicy(tiny_config(obs_mode=mode, invariant_weight=0.0), _stats())
    assert without.losses(batch)["invar"] == 0.0


def test_the_object_loss_trains_the_encoders_from_the_privileged_poses_and_nothing_else():
    torch.manual_seed(0)
    config = tiny_config(obs_mode="image", invariant_weight=0.0, object_aux_weight=2.0)
    policy = RecurrentGMMPolicy(config, _stats())
    assert policy.loss_terms == ("nll", "ce", "invar", "aux", "total")
    batch = _batch(image=16)
    losses = policy.losses(batch)
    value = {k: float(v.detach()) for k, v in losses.items()}
    assert value["aux"] > 0
    assert value["total"] == pytest.approx(value["nll"] + config.grasp_weight * value["ce"]
                                           + 2.0 * value["aux"], rel=1e-5)
    losses["aux"].backward()
    assert policy.encoders["left_gray"].trunk[0].weight.grad.abs().sum() > 0
    assert policy.object_head.linear.weight.grad.abs().sum() > 0
    assert policy.rnn.weight_ih_l0.grad is None  # the LSTM and heads are not its business
    # It regresses the normalised poses: a head that outputs them exactly scores 0.
    with torch.no_grad():
        norm = policy.object_head.normalizer
        policy.object_head.linear.weight.zero_()
        policy.object_head.linear.bias.copy_(-norm.mean / norm.std)
    zero = {**batch, "obs": {**batch["obs"],
                             "object_in_tcp": torch.zeros_like(batch["obs"]["object_in_tcp"])}}
    assert float(policy.losses(zero)["aux"].detach()) == pytest.approx(0.0, abs=1e-6)
    # The diagnostic reads the head in raw units: that head's poses are zero everywhere.
    estimate = policy.estimate_objects(batch["obs"])
    assert estimate.shape == batch["obs"]["object_in_tcp"].shape
    assert float(estimate.abs().max()) == pytest.approx(0.0, abs=1e-5)
    plain = RecurrentGMMPolicy(tiny_config(obs_mode="image", invariant_weight=0.0), _stats())
    assert "aux" not in plain.losses(batch) and plain.object_head is None
    with pytest.raises(ValueError, match="object_aux_weight"):
        plain.estimate_objects(batch["obs"])


def test_the_object_head_loads_the_names_older_checkpoints_gave_it():
    config = tiny_config(obs_mode="image", invariant_weight=0.0, object_aux_weight=1.0,
                         ema=True)
    policy = RecurrentGMMPolicy(config, _stats())
    state = policy.state_dict()
    legacy = {}
    for key, value in state.items():  # the names before ObjectHead, in the policy and its EMA
        for new, old in (("object_head.linear.", "object_head."),
                         ("object_head.normalizer.", "object_normalizer.")):
            key = key.replace(new, old)
        legacy[key] = value + 1.0 if "object_head" in key else value
    assert "ema.object_normalizer.std" in legacy and "object_head.weight" in legacy
    loaded = RecurrentGMMPolicy(config, _stats())
    loaded.load_state_dict(legacy)
    torch.testing.assert_close(loaded.object_head.linear.weight,
                               state["object_head.linear.weight"] + 1.0)
    torch.testing.assert_close(loaded.ema.object_head.linear.bias,
                               state["ema.object_head.linear.bias"] + 1.0)


def test_normalizer_round_trip():
    data = np.random.default_rng(1).normal(3.0, [0.1, 2.0, 0.0], (100, 3))
    stats = compute_stats([data])
    assert stats["std"][2] == 1.0  # a constant dimension is not blown up
    norm = Normalizer(stats["mean"], stats["std"])
    x = torch.from_numpy(data).float()
    torch.testing.assert_close(norm.inverse(norm(x)), x)
    assert norm(x)[:, :2].std(0).sub(1.0).abs().max() < 0.02


def test_barely_varying_observations_are_not_blown_up():
    data = np.random.default_rng(2).normal(0.0, [1e-5, 0.05], (200, 2))
    stats = compute_stats([data], OBS_MIN_STD)
    assert stats["std"][0] == np.float32(OBS_MIN_STD)
    assert stats["std"][1] == pytest.approx(0.05, rel=0.2)
    assert compute_stats([data])["std"][0] == pytest.approx(1e-5, rel=0.2)  # actions


def test_rollout_images_are_preprocessed_as_in_training(tmp_path):
    path = synthetic_dataset(tmp_path / "d.hdf5", demos=2, length=6)
    dataset = DemoSequenceDataset(path, seq_length=3, split="all")
    item = dataset[0]
    import h5py

    with h5py.File(path, "r") as f:
        frame = f["data/demo_0/obs/left_gray"][0]  # (H, W, 1) uint8, what the camera outputs
    torch.testing.assert_close(image_to_tensor(frame), item["obs"]["left_gray"][0])
    assert image_to_tensor(frame).shape == (1, 16, 16)


@pytest.mark.parametrize("history", [0, 1, 2])
def test_history_switch_sets_what_the_network_receives(history):
    """``history`` pose-delta steps reach the network (the last ones); the rest of the
    history never changes its output."""
    config = tiny_config(history=history, invariant_weight=0.0)
    assert (("delta_positions" in config.obs_keys) == (history > 0))
    assert {"delta_positions", "delta_eulers"} <= set(config.dataset_keys)
    policy = RecurrentGMMPolicy(config, _stats()).eval()
    state_dims = 27 + 2  # object_in_tcp (3 bodies) + fingers
    assert policy.rnn.input_size == state_dims + 6 * history
    batch = _batch()
    out, _ = policy(batch["obs"])
    changed = {k: v.clone() for k, v in batch["obs"].items()}
    seen = slice(3 * (2 - history), 6)
    unseen = slice(0, 3 * (2 - history))
    for key in ("delta_positions", "delta_eulers"):
        changed[key][..., unseen] += 1.0
    torch.testing.assert_close(policy(changed)[0].means, out.means)
    if history:
        for key in ("delta_positions", "delta_eulers"):
            changed[key][..., seen] += 1.0
        assert not torch.allclose(policy(changed)[0].means, out.means)


def test_invariant_loss_reads_the_dataset_history_when_the_network_does_not():
    """Appendix A needs the demonstrated history for phi even with ``history: 0``."""
    torch.manual_seed(0)
    policy = RecurrentGMMPolicy(tiny_config(history=0, invariant_weight=1.0), _stats())
    batch = _batch()
    invar = policy.losses(batch)["invar"]
    turned = batch["obs"]["delta_positions"].flip(-1)  # other directions of motion
    other = {**batch, "obs": {**batch["obs"], "delta_positions": turned}}
    assert invar > 0 and not torch.isclose(policy.losses(other)["invar"], invar)
    out, _ = policy(batch["obs"])
    torch.testing.assert_close(policy(other["obs"])[0].means, out.means)  # not an input


def test_history_noise_and_dropout_act_in_training_only():
    config = tiny_config(history=2, history_noise=0.5, history_dropout=0.5,
                         invariant_weight=0.0)
    policy = RecurrentGMMPolicy(config, _stats())
    obs = _batch()["obs"]
    policy.eval()
    torch.testing.assert_close(policy.features(obs), policy.features(obs))
    policy.train()
    assert not torch.allclose(policy.features(obs), policy.features(obs))
    clean = RecurrentGMMPolicy(tiny_config(history=2, invariant_weight=0.0), _stats()).train()
    torch.testing.assert_close(clean.features(obs), clean.features(obs))


def test_window_memory_acts_on_the_last_seq_length_frames_and_reset_memory_restarts():
    """``rnn_memory``: ``reset`` restarts the LSTM every ``seq_length`` steps; ``window``
    reruns it from a zero state over the last ``seq_length`` frames. The two agree until the
    first reset and differ after it."""
    L, steps = 4, 11
    torch.manual_seed(0)
    reset = RecurrentGMMPolicy(tiny_config(seq_length=L), _stats()).eval()
    window = RecurrentGMMPolicy(tiny_config(seq_length=L, rnn_memory="window"), _stats()).eval()
    window.load_state_dict(reset.state_dict())
    obs = _batch()["obs"]
    frames = [{k: v[:1, t] for k, v in obs.items()} for t in range(T)] * 3
    state_r, state_w, acted_r, acted_w = reset.initial_state(), window.initial_state(), [], []
    for t in range(steps):
        action, state_r = reset.act(frames[t], state_r)
        acted_r.append(action[0, 0])
        action, state_w = window.act(frames[t], state_w)
        acted_w.append(action[0, 0])
        assert len(state_w.window) == min(t + 1, L - 1)

    def from_zero(first: int, last: int) -> torch.Tensor:
        """The action at ``last`` of the LSTM run from a zero state over frames first..last."""
        run = {k: torch.stack([frames[t][k] for t in range(first, last + 1)], 1)
               for k in frames[0]}
        with torch.no_grad():
            return reset.mode_action(reset(run)[0])[0, -1]

    for t in range(steps):
        torch.testing.assert_close(acted_w[t], from_zero(max(0, t - L + 1), t))
        torch.testing.assert_close(acted_r[t], from_zero(t - t % L, t))
    torch.testing.assert_close(torch.stack(acted_w[:L]), torch.stack(acted_r[:L]))
    assert not torch.allclose(torch.stack(acted_w[L:]), torch.stack(acted_r[L:]))


def test_mixture_mean_acts_on_the_weighted_components_and_keeps_the_grasp():
    """``gmm_action``: ``most_likely`` acts on the most likely component's mean,
    ``mixture_mean`` on the probability-weighted mean of all components; the grasp and the
    training losses are the same either way."""
    torch.manual_seed(0)
    likely = RecurrentGMMPolicy(tiny_config(), _stats()).eval()
    mixed = RecurrentGMMPolicy(tiny_config(gmm_action="mixture_mean"), _stats()).eval()
    mixed.load_state_dict(likely.state_dict())
    obs = _batch()["obs"]
    frame = {k: v[:, 0] for k, v in obs.items()}
    a_likely, _ = likely.act(frame, likely.initial_state())
    a_mixed, _ = mixed.act(frame, mixed.initial_state())
    with torch.no_grad():
        out, _ = likely({k: v[:, :1] for k, v in obs.items()})
    norm = likely.normalizers["actions"]
    weights = torch.softmax(out.logits, -1)[..., None]
    expected = (weights * out.means).sum(-2)[..., :6] * norm.std[:6] + norm.mean[:6]
    torch.testing.assert_close(a_mixed[..., :6], expected)
    torch.testing.assert_close(a_likely, likely.mode_action(out))
    assert not torch.allclose(a_mixed[..., :6], a_likely[..., :6])
    torch.testing.assert_close(a_mixed[..., 6], a_likely[..., 6])
    batch = _batch()
    torch.manual_seed(1)
    loss_likely = likely.train().losses(batch)["total"]
    torch.manual_seed(1)
    loss_mixed = mixed.train().losses(batch)["total"]
    torch.testing.assert_close(loss_likely, loss_mixed)
    with pytest.raises(ConfigError, match="gmm_action.*most_likely, mixture_mean"):
        tiny_config(gmm_action="mean")


def test_the_weight_average_follows_the_trained_weights_and_is_what_validates_and_acts():
    """``ema``: the trained parameters are those of a policy without it (same values, same
    order); ``after_step`` moves the frozen copy ``1 - decay`` of the way to them; validation
    and rollout run the copy."""
    torch.manual_seed(0)
    plain = RecurrentGMMPolicy(tiny_config(), _stats())
    torch.manual_seed(0)
    averaged = RecurrentGMMPolicy(tiny_config(ema=True, ema_decay=0.9), _stats())
    trained = [p for p in averaged.parameters() if p.requires_grad]
    assert len(trained) == len(list(plain.parameters()))
    for mine, theirs in zip(trained, plain.parameters(), strict=True):
        assert torch.equal(mine, theirs)
    batch = _batch()
    before = [p.clone() for p in averaged.ema.parameters()]
    averaged.losses(batch)["total"].backward()
    torch.optim.SGD(trained, lr=0.5).step()
    averaged.after_step(1000)  # decay min(0.9, 1001 / 1010) = 0.9
    for mean, old, new in zip(averaged.ema.parameters(), before, trained, strict=True):
        torch.testing.assert_close(mean, 0.9 * old + 0.1 * new.detach())
    averaged.eval()
    as_average = RecurrentGMMPolicy(tiny_config(), _stats()).eval()
    as_average.load_state_dict(averaged.ema.state_dict())
    as_trained = RecurrentGMMPolicy(tiny_config(), _stats()).eval()
    as_trained.load_state_dict({k: v for k, v in averaged.state_dict().items()
                                if not k.startswith("ema.")})
    with torch.no_grad():
        loss = averaged.losses(batch)["total"]
        torch.testing.assert_close(loss, as_average.losses(batch)["total"])
        assert not torch.allclose(loss, as_trained.losses(batch)["total"])
    obs = {k: v[:, 0] for k, v in batch["obs"].items()}
    action, _ = averaged.act(obs, averaged.initial_state())
    torch.testing.assert_close(action, as_average.act(obs, as_average.initial_state())[0])
    assert not torch.allclose(action, as_trained.act(obs, as_trained.initial_state())[0])
    # a shipped checkpoint keeps the average alone, and acts as it does
    kept = averaged.rollout_state_dict()
    assert kept and all(k.startswith("ema.") for k in kept)
    shipped = RecurrentGMMPolicy(tiny_config(ema=True), _stats()).eval()
    shipped.load_rollout_state_dict(kept)
    torch.testing.assert_close(shipped.act(obs, shipped.initial_state())[0], action)
    with pytest.raises(ConfigError, match="ema .*for legato and bc_rnn"):
        tiny_config(algo="dp_velocity", ema=True)
