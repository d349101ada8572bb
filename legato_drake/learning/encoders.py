"""Image encoders: a conv trunk, spatial-softmax keypoints and a linear layer per camera.

``ImageEncoder`` maps one 1-channel image (B, 1, H, W) in [0, 1] to a feature (B, feature_dim):
conv trunk (ResNet-18 without its pooling and classifier, or ``small_trunk``'s few 3x3
convs), a 1x1 conv to K keypoint maps, a spatial softmax giving each map's expected (x, y)
in [-1, 1], and a linear layer from the 2K coordinates (robomimic's ``VisualCore``). The
images reach it through ``data.torch_dataset.image_to_tensor``, the one preprocessing of
training and rollout.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch
import torch.nn.functional as F  # noqa: N812 - the usual torch name
from torch import nn

if TYPE_CHECKING:
    from legato_drake.learning.config import LearningConfig


class BasicBlock(nn.Module):
    """ResNet's two-conv residual block."""

    def __init__(self, cin: int, cout: int, stride: int):
        super().__init__()
        self.conv1 = nn.Conv2d(cin, cout, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(cout)
        self.conv2 = nn.Conv2d(cout, cout, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(cout)
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, bias=False),
                                      nn.BatchNorm2d(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        identity = x if self.down is None else self.down(x)
        y = torch.relu(self.bn1(self.conv1(x)))
        return torch.relu(self.bn2(self.conv2(y)) + identity)


def resnet18_trunk(in_channels: int = 1) -> tuple[nn.Module, int]:
    """ResNet-18's conv layers (not pretrained) for ``in_channels`` input; (trunk, out
    channels). A 128x128 image gives 512 x 4 x 4."""
    layers: list[nn.Module] = [nn.Conv2d(in_channels, 64, 7, 2, 3, bias=False),
                               nn.BatchNorm2d(64), nn.ReLU(inplace=True),
                               nn.MaxPool2d(3, 2, 1)]
    cin = 64
    for cout, stride in ((64, 1), (128, 2), (256, 2), (512, 2)):
        layers += [BasicBlock(cin, cout, stride), BasicBlock(cout, cout, 1)]
        cin = cout
    return nn.Sequential(*layers), cin


def small_trunk(channels: list[int], in_channels: int = 1,
                strides: list[int] | None = None) -> tuple[nn.Module, int]:
    """A small CPU trunk: 3x3 convs at ``strides`` (2 each by default: 128x128 -> 16x16 with
    3 layers), each with GroupNorm and ReLU. Without the normalisation this shallow stack's
    features are about 0.003 in size at initialisation and every image's keypoints the same to
    2e-4; trained with LEGATO's whole loss it then learned no grasp from the images (the NLL's
    gradient, 100-1000 in norm, swamps the rest). GroupNorm rather than BatchNorm, as
    Diffusion Policy does: its statistics do not depend on the batch, so training and rollout
    run the same network."""
    layers: list[nn.Module] = []
    cin = in_channels
    for cout, stride in zip(channels, strides or [2] * len(channels), strict=True):
        layers += [nn.Conv2d(cin, cout, 3, stride, 1, bias=False),
                   nn.GroupNorm(max(1, cout // 8), cout), nn.ReLU(inplace=True)]
        cin = cout
    return nn.Sequential(*layers), cin


class SpatialSoftmax(nn.Module):
    """Keypoints: a 1x1 conv to K maps, a softmax over each map's pixels, and the expected
    pixel coordinates (x, y) in [-1, 1] (x along the width, y along the height); (B, C, H, W)
    -> (B, K, 2)."""

    def __init__(self, channels: int, keypoints: int):
        super().__init__()
        self.project = nn.Conv2d(channels, keypoints, 1)

    @staticmethod
    def attention(maps: torch.Tensor) -> torch.Tensor:
        """(B, K, H, W) logits -> (B, K, H * W): each keypoint's softmax over the pixels."""
        B, K, H, W = maps.shape
        return torch.softmax(maps.reshape(B, K, H * W), -1)

    @classmethod
    def expected_xy(cls, maps: torch.Tensor) -> torch.Tensor:
        """(B, K, H, W) logits -> (B, K, 2) expected (x, y) of their softmax."""
        B, K, H, W = maps.shape
        attention = cls.attention(maps).reshape(B, K, H, W)
        xs = torch.linspace(-1.0, 1.0, W, device=maps.device, dtype=maps.dtype)
        ys = torch.linspace(-1.0, 1.0, H, device=maps.device, dtype=maps.dtype)
        x = (attention.sum(-2) * xs).sum(-1)
        y = (attention.sum(-1) * ys).sum(-1)
        return torch.stack([x, y], -1)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.expected_xy(self.project(features))


def resize_images(images: torch.Tensor, size: int) -> torch.Tensor:
    """Images (N, C, H, W) scaled to ``size`` x ``size`` by area averaging: the whole view at
    a lower resolution (``image_resize``), in training and at rollout alike."""
    if tuple(images.shape[-2:]) == (size, size):
        return images
    return F.interpolate(images, size=(size, size), mode="area")


def crop_images(images: torch.Tensor, size: int, random: bool) -> torch.Tensor:
    """Square ``size`` crops of images (N, C, H, W): at a random offset per image
    (``random``, training: robomimic's crop randomizer) or at the centre (rollout). The one
    crop of training and rollout: ``ImageEncoder`` applies it in its forward, random in
    ``train()`` mode and centred in ``eval()`` mode."""
    N, _, H, W = images.shape
    if size > min(H, W):
        raise ValueError(f"image_crop {size} is larger than the {H}x{W} images")
    if not random:
        top, left = (H - size) // 2, (W - size) // 2
        return images[:, :, top:top + size, left:left + size]
    top = torch.randint(0, H - size + 1, (N,), device=images.device)
    left = torch.randint(0, W - size + 1, (N,), device=images.device)
    steps = torch.arange(size, device=images.device)
    rows = (top[:, None] + steps)[:, :, None]                     # (N, size, 1)
    cols = (left[:, None] + steps)[:, None, :]                    # (N, 1, size)
    batch = torch.arange(N, device=images.device)[:, None, None]
    return images.permute(0, 2, 3, 1)[batch, rows, cols].permute(0, 3, 1, 2)


class ImageEncoder(nn.Module):
    """One camera's encoder: (B, 1, H, W) in [0, 1] -> (B, feature_dim).

    ``resize`` (0: none) scales the images to that size first (``resize_images``), then
    ``crop`` (0: none) crops them (``crop_images``: random while training, centred at
    rollout). ``channels`` and ``strides`` shape the small trunk (``small_trunk``). The
    convolutions run channels-last (twice as fast as channels-first on this project's CPUs,
    measured by ``benchmarks/bench_training_step.py``) and, with
    ``precision="bfloat16"``, under bfloat16 autocast (twice again where the CPU has
    AVX-512 BF16; the trunk only: the keypoints and everything after stay float32)."""

    def __init__(self, trunk: str = "resnet18", keypoints: int = 32, feature_dim: int = 64,
                 channels: list[int] | None = None, crop: int = 0,
                 precision: str = "float32", resize: int = 0,
                 strides: list[int] | None = None):
        super().__init__()
        if trunk == "resnet18":
            self.trunk, out = resnet18_trunk(1)
        else:
            self.trunk, out = small_trunk(list(channels or [16, 32, 32]), 1, strides)
        self.keypoints = SpatialSoftmax(out, keypoints)
        self.linear = nn.Linear(2 * keypoints, feature_dim)
        self.resize, self.crop = resize, crop
        self.precision = precision
        self.to(memory_format=torch.channels_last)

    @classmethod
    def from_config(cls, config: LearningConfig) -> ImageEncoder:
        """The encoder of one camera as ``config`` describes it."""
        return cls(config.encoder, config.keypoints, config.feature_dim,
                   config.encoder_channels, config.image_crop, config.encoder_precision,
                   config.image_resize, config.encoder_strides)

    def trunk_features(self, image: torch.Tensor) -> torch.Tensor:
        """(B, 1, H, W) -> the trunk's feature maps (float32), as ``forward`` computes them."""
        if self.resize:
            image = resize_images(image, self.resize)
        if self.crop:
            image = crop_images(image, self.crop, random=self.training)
        image = image.contiguous(memory_format=torch.channels_last)
        with torch.autocast(image.device.type, dtype=torch.bfloat16,
                            enabled=self.precision == "bfloat16"):
            return self.trunk(image).float()

    def keypoint_attention(self, image: torch.Tensor) -> torch.Tensor:
        """(B, 1, H, W) -> (B, K, pixels): each keypoint's softmax over the feature map (a
        diagnostic of how sharply the keypoints point: ``scripts/legato_fit.py``)."""
        return self.keypoints.attention(self.keypoints.project(self.trunk_features(image)))

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        return self.linear(self.keypoints(self.trunk_features(image)).flatten(1))


def encode_sequence(encoder: nn.Module, images: torch.Tensor) -> torch.Tensor:
    """Images (B, T, 1, H, W) -> features (B, T, F), every step through ``encoder``."""
    B, T = images.shape[:2]
    return encoder(images.reshape(B * T, *images.shape[2:])).reshape(B, T, -1)
