"""StereoCamera alone: image size and type, upright and not mirrored, stereo baseline."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.geometry import (
    GeometryInstance,
    MakePhongIllustrationProperties,
    MakeRenderEngineVtk,
    PerceptionProperties,
    RenderEngineVtkParams,
    SceneGraph,
    Sphere,
)
from pydrake.geometry import Rgba as GeometryRgba
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from legato_drake.systems.fisheye import FisheyeLens, pinhole_matrix, pinhole_project
from legato_drake.systems.stereo_camera import RENDERER_NAME, StereoCamera, StereoRig

# Drake's camera convention: +z forward, +x right, +y down. A camera looking along world +x
# with world +z up: camera x = world -y, camera y = world -z, camera z = world +x.
_R_WC = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _camera_with_ball(ball_position, baseline=0.064, lens=None, radius=0.05):
    """A camera rig at the world origin looking along +x, and one white ball. Returns the
    camera, its context, the diagram and the diagram's context."""
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    scene_graph.AddRenderer(RENDERER_NAME, MakeRenderEngineVtk(
        RenderEngineVtkParams(default_clear_color=[0.0, 0.0, 0.0])))
    source = scene_graph.RegisterSource("test")
    ball = GeometryInstance(RigidTransform(ball_position), Sphere(radius), "ball")
    perception = PerceptionProperties()
    perception.AddProperty("phong", "diffuse", GeometryRgba(1, 1, 1, 1))
    ball.set_perception_properties(perception)
    ball.set_illustration_properties(MakePhongIllustrationProperties([1, 1, 1, 1]))
    scene_graph.RegisterAnchoredGeometry(source, ball)
    R = RotationMatrix(_R_WC)
    rig = StereoRig(scene_graph.world_frame_id(),
                    RigidTransform(R, [0, baseline / 2, 0]),
                    RigidTransform(R, [0, -baseline / 2, 0]), lens=lens)
    camera = builder.AddSystem(StereoCamera(rig))
    builder.Connect(scene_graph.get_query_output_port(), camera.get_geometry_query_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    return camera, camera.GetMyContextFromRoot(context), diagram, context


def _weighted_centroid(image):
    """The intensity-weighted centroid (x, y) of an image (finer than thresholding)."""
    w = image[:, :, 0].astype(float)
    assert w.max() > 128, "the ball is not in the image"
    ys, xs = np.mgrid[:w.shape[0], :w.shape[1]]
    return np.array([(w * xs).sum(), (w * ys).sum()]) / w.sum()


def _centroid(image):
    ys, xs = np.nonzero(image[:, :, 0] > 128)
    assert len(xs) > 0, "the ball is not in the image"
    return xs.mean(), ys.mean()


def test_images_are_128x128x1_uint8():
    camera, context, *_ = _camera_with_ball([0.5, 0, 0])
    left, right = camera.render(context)
    for image in (left, right):
        assert image.shape == (128, 128, 1) and image.dtype == np.uint8


@pytest.mark.parametrize("offset, expect", [
    ([0.5, 0.2, 0.0], "left"), ([0.5, -0.2, 0.0], "right"),
    ([0.5, 0.0, 0.2], "top"), ([0.5, 0.0, -0.2], "bottom")])
def test_upright_and_not_mirrored(offset, expect):
    camera, context, *_ = _camera_with_ball(offset)
    left, _ = camera.render(context)
    x, y = _centroid(left)
    assert {"left": x < 54, "right": x > 74, "top": y < 54, "bottom": y > 74}[expect]


def test_stereo_disparity_has_the_right_sign():
    camera, context, *_ = _camera_with_ball([0.3, 0.0, 0.0])
    left, right = camera.render(context)
    # The ball straight ahead appears right of centre to the left camera, left to the right.
    assert _centroid(left)[0] > _centroid(right)[0] + 2


def test_periodic_update_fills_the_output_ports():
    camera, context, diagram, root_context = _camera_with_ball([0.5, 0.0, 0.0])
    blank = camera.GetOutputPort("left_gray").Eval(context)
    assert blank.max() == 0
    Simulator(diagram, root_context).AdvanceTo(0.01)  # the first periodic render, at t = 0
    assert camera.GetOutputPort("left_gray").Eval(context).max() > 128


@pytest.mark.parametrize("model", ["pinhole", "fisheye"])
def test_a_known_point_lands_where_the_camera_model_projects_it(model):
    """A small ball 35 degrees off the axis is imaged at its centre's projection: Drake's
    pinhole for ``pinhole``, OpenCV's fisheye model for ``fisheye`` (the remapped render)."""
    lens = FisheyeLens() if model == "fisheye" else None
    ball = np.array([0.5, -0.2, 0.25])  # world: ahead, to the right, above
    camera, context, *_ = _camera_with_ball(ball, baseline=0.0, lens=lens, radius=0.02)
    left, _ = camera.render(context)
    assert left.shape == (128, 128, 1) and left.dtype == np.uint8
    p_C = _R_WC.T @ ball
    if lens is None:
        expected = pinhole_project(pinhole_matrix(128, 128, np.radians(120.0)), p_C)
    else:
        expected = lens.project(p_C)
        # OpenCV's fisheye is the equidistant lens: r = f * theta.
        theta = np.arctan2(np.hypot(p_C[0], p_C[1]), p_C[2])
        direction = p_C[:2] / np.hypot(p_C[0], p_C[1])
        np.testing.assert_allclose(expected, lens.K[:2, 2] + lens.focal * theta * direction,
                                   atol=1e-9)
    # Off the axis a sphere's image is not centred on its centre's projection: 0.3-0.5 px
    # here.
    assert np.hypot(*(_weighted_centroid(left) - expected)) < 0.75


def test_the_render_centre_is_half_a_pixel_before_camera_info():
    """The principal point ``pinhole_matrix`` uses, measured on a ball on the axis."""
    camera, context, *_ = _camera_with_ball([0.5, 0, 0], baseline=0.0, radius=0.02)
    np.testing.assert_allclose(_centroid(camera.render(context)[0]),
                               pinhole_matrix(128, 128, np.radians(120.0))[:2, 2], atol=0.05)


def test_the_fisheye_sees_wider_than_the_pinhole_at_the_corners():
    """The centre-cropped fisheye sees 112 degrees across its sides (the 120-degree pinhole:
    120) but 158 across its diagonal (the pinhole: 136): a ball 74 degrees off the axis
    toward the lower right corner is outside the pinhole's view and inside the fisheye's."""
    ball = np.array([0.15, -0.37, -0.37])  # camera frame: x = y = 2.47 z
    pinhole, context, *_ = _camera_with_ball(ball, baseline=0.0, radius=0.03)
    assert pinhole.render(context)[0].max() < 128
    lens = FisheyeLens()
    fisheye, context, *_ = _camera_with_ball(ball, baseline=0.0, lens=lens, radius=0.015)
    centroid = _weighted_centroid(fisheye.render(context)[0])
    assert np.hypot(*(centroid - lens.project(_R_WC.T @ ball))) < 1.0
    pinhole_corner = np.arctan(np.sqrt(2) * np.tan(np.radians(60)))
    assert np.degrees(lens.max_angle) > 74 > np.degrees(pinhole_corner)
