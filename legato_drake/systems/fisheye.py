"""The T265-like fisheye lens of the gripper camera (SPEC §3): a wide pinhole render remapped.

The real camera is a 163° (diagonal) fisheye on an 848 x 800 sensor; LEGATO centre-crops its
images to 800 x 800 and resizes them to 128 x 128. We model it with OpenCV's fisheye model
(``cv2.fisheye``: equidistant, ``r = f theta`` with distortion ``D``, zero here) and make
the image in two steps: a pinhole render wide and fine enough to hold every ray the cropped
fisheye sees, then ``cv2.remap`` through maps computed once by
``cv2.fisheye.undistortPoints`` (each fisheye pixel's ray, as a pixel of the pinhole render).

All cameras here follow Drake's convention: +z forward, +x right, +y down in the image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

T265_SENSOR = (848, 800)
"""The T265's fisheye sensor, width x height in pixels."""


def pinhole_matrix(width: int, height: int, fov_y: float) -> np.ndarray:
    """The intrinsic matrix of a Drake VTK render with ``CameraInfo(width, height, fov_y)``,
    in pixel-index coordinates (pixel (0, 0)'s centre at (0, 0)). Its principal point is
    measured, not ``CameraInfo``'s: a ball on the optical axis images centred at
    (width / 2 - 1, height / 2 - 1), half a pixel before ``center_x()`` and ``center_y()``
    (63.0, not 63.5, at 128; ``tests/test_stereo_camera.py`` checks it)."""
    f = height / 2.0 / math.tan(fov_y / 2.0)
    return np.array([[f, 0.0, width / 2.0 - 1.0], [0.0, f, height / 2.0 - 1.0],
                     [0.0, 0.0, 1.0]])


def pinhole_project(K: np.ndarray, p_C: np.ndarray) -> np.ndarray:
    """Pixel (u, v) of a point in the camera frame through the pinhole ``K``."""
    p = K @ (np.asarray(p_C, dtype=float) / p_C[2])
    return p[:2]


@dataclass(frozen=True)
class FisheyeLens:
    """A fisheye of ``fov_deg`` across the diagonal of ``sensor``, centre-cropped to its
    largest square and resized to ``width`` x ``height``."""

    width: int = 128
    height: int = 128
    fov_deg: float = 163.0
    sensor: tuple[int, int] = T265_SENSOR

    @property
    def focal(self) -> float:
        """The output image's focal length in pixels (equidistant: r = f theta)."""
        sensor_w, sensor_h = self.sensor
        f_sensor = math.hypot(sensor_w, sensor_h) / 2.0 / math.radians(self.fov_deg / 2.0)
        return f_sensor * self.width / min(sensor_w, sensor_h)

    @property
    def K(self) -> np.ndarray:
        """The fisheye's intrinsic matrix (principal point at the image centre)."""
        return np.array([[self.focal, 0.0, self.width / 2.0 - 0.5],
                         [0.0, self.focal, self.height / 2.0 - 0.5], [0.0, 0.0, 1.0]])

    @property
    def D(self) -> np.ndarray:
        """OpenCV fisheye distortion [k1, k2, k3, k4]: zero, the ideal equidistant lens."""
        return np.zeros(4)

    @property
    def max_angle(self) -> float:
        """The widest ray the output image sees (its corners), radians from the axis."""
        return math.hypot(self.width, self.height) / 2.0 / self.focal

    @property
    def render_fov_y(self) -> float:
        """Vertical field of view of the pinhole render that holds every ray of the image."""
        corner = math.tan(self.max_angle) / math.sqrt(2.0)  # a corner's x (and y) / z
        return 2.0 * math.atan(corner * 1.02)

    @property
    def render_size(self) -> int:
        """Side of the square pinhole render: as fine at its centre as the fisheye's."""
        half = math.tan(self.render_fov_y / 2.0)
        return int(2 * math.ceil(self.focal * half))

    def project(self, p_C: np.ndarray) -> np.ndarray:
        """Pixel (u, v) of a point in the camera frame (OpenCV's fisheye projection)."""
        points = np.asarray(p_C, dtype=np.float64).reshape(1, 1, 3)
        uv, _ = cv2.fisheye.projectPoints(points, np.zeros(3), np.zeros(3), self.K, self.D)
        return uv.reshape(2)

    @cached_property
    def maps(self) -> tuple[np.ndarray, np.ndarray]:
        """``cv2.remap`` maps: for every fisheye pixel, where its ray falls in the render."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64),
                           np.arange(self.height, dtype=np.float64))
        pixels = np.stack([u.ravel(), v.ravel()], axis=-1).reshape(-1, 1, 2)
        side = self.render_size
        K_render = pinhole_matrix(side, side, self.render_fov_y)
        undistorted = cv2.fisheye.undistortPoints(pixels, self.K, self.D, P=K_render)
        xy = undistorted.reshape(self.height, self.width, 2).astype(np.float32)
        return xy[..., 0].copy(), xy[..., 1].copy()

    def remap(self, render: np.ndarray) -> np.ndarray:
        """The fisheye image from a pinhole render of ``render_size`` at ``render_fov_y``."""
        map_x, map_y = self.maps
        return cv2.remap(render, map_x, map_y, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0)
