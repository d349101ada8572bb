"""The LEGATO gripper's stereo camera: two grayscale images at 10 Hz."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    ColorRenderCamera,
    FrameId,
    QueryObject,
    RenderCameraCore,
)
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context, LeafSystem, State
from pydrake.systems.sensors import CameraInfo

from legato_drake import conventions
from legato_drake.systems.fisheye import FisheyeLens

RENDERER_NAME = "legato_vtk"


@dataclass(frozen=True)
class StereoRig:
    """Where the two cameras sit and what they see."""

    parent_frame: FrameId
    """SceneGraph frame the cameras are attached to (the gripper base body)."""
    X_P_left: RigidTransform
    """Pose of the left camera (Drake camera convention: +z forward, +y down) in the parent."""
    X_P_right: RigidTransform
    width: int = 128
    height: int = 128
    fov_y: float = np.radians(120.0)
    """Vertical field of view of the pinhole model (unused with a ``lens``)."""
    renderer: str = RENDERER_NAME
    lens: FisheyeLens | None = None
    """A fisheye lens (``camera.model: fisheye``): the images are its remap of a wider render;
    ``width`` and ``height`` are then the lens's."""

    def render_camera(self) -> ColorRenderCamera:
        """The pinhole camera both cameras render with (for a fisheye, its wide render)."""
        if self.lens is not None:
            side = self.lens.render_size
            info = CameraInfo(width=side, height=side, fov_y=self.lens.render_fov_y)
        else:
            info = CameraInfo(width=self.width, height=self.height, fov_y=self.fov_y)
        core = RenderCameraCore(self.renderer, info, ClippingRange(0.01, 10.0),
                                RigidTransform())
        return ColorRenderCamera(core, show_window=False)


class StereoCamera(LeafSystem):
    """Renders the gripper's two cameras every ``period`` and converts them to grayscale.

    Pinhole by default; with the rig's ``lens``, a fisheye (``systems.fisheye``). Images are
    ``height x width x 1`` uint8 arrays, row 0 at the top, column 0 at the left as a
    person behind the gripper looking along its approach axis sees the scene (upright and not
    mirrored; the reference's images were mirrored).

    Input ports:
        geometry_query: SceneGraph's query object.

    Output ports:
        left_gray, right_gray (numpy uint8 array, H x W x 1): the images of the last render.

    State: abstract, the two images of the last render (black before the first).
    """

    def __init__(self, rig: StereoRig, period: float = conventions.POLICY_PERIOD,
                 offset: float = conventions.CAMERA_OFFSET):
        super().__init__()
        self._rig = rig
        self._camera = rig.render_camera()
        self._query = self.DeclareAbstractInputPort(
            "geometry_query", AbstractValue.Make(QueryObject()))
        blank = np.zeros((rig.height, rig.width, 1), dtype=np.uint8)
        self._left = self.DeclareAbstractState(AbstractValue.Make(blank))
        self._right = self.DeclareAbstractState(AbstractValue.Make(blank.copy()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, offset, self._render)
        for name, index in (("left_gray", self._left), ("right_gray", self._right)):
            self.DeclareStateOutputPort(name, index)

    def get_geometry_query_input_port(self):
        return self._query

    def render(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        """Renders both cameras now and returns the (left, right) grayscale images."""
        query = self._query.Eval(context)
        images = []
        for X_PC in (self._rig.X_P_left, self._rig.X_P_right):
            rgba = query.RenderColorImage(self._camera, self._rig.parent_frame, X_PC)
            gray = cv2.cvtColor(rgba.data, cv2.COLOR_RGBA2GRAY)
            if self._rig.lens is not None:
                gray = self._rig.lens.remap(gray)
            images.append(gray[:, :, np.newaxis])
        return images[0], images[1]

    def _render(self, context: Context, state: State) -> None:
        left, right = self.render(context)
        state.get_mutable_abstract_state(self._left).set_value(left)
        state.get_mutable_abstract_state(self._right).set_value(right)
