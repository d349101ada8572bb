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

from legato_drake.systems.stereo_camera import RENDERER_NAME, StereoCamera, StereoRig

# Drake's camera convention: +z forward, +x right, +y down. A camera looking along world +x
# with world +z up: camera x = world -y, camera y = world -z, camera z = world +x.
_R_WC = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _camera_with_ball(ball_position, baseline=0.064):
    """A camera rig at the world origin looking along +x, and one white ball. Returns the
    camera, its context, the diagram and the diagram's context."""
    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    scene_graph.AddRenderer(RENDERER_NAME, MakeRenderEngineVtk(
        RenderEngineVtkParams(default_clear_color=[0.0, 0.0, 0.0])))
    source = scene_graph.RegisterSource("test")
    ball = GeometryInstance(RigidTransform(ball_position), Sphere(0.05), "ball")
    perception = PerceptionProperties()
    perception.AddProperty("phong", "diffuse", GeometryRgba(1, 1, 1, 1))
    ball.set_perception_properties(perception)
    ball.set_illustration_properties(MakePhongIllustrationProperties([1, 1, 1, 1]))
    scene_graph.RegisterAnchoredGeometry(source, ball)
    R = RotationMatrix(_R_WC)
    rig = StereoRig(scene_graph.world_frame_id(),
                    RigidTransform(R, [0, baseline / 2, 0]),
                    RigidTransform(R, [0, -baseline / 2, 0]))
    camera = builder.AddSystem(StereoCamera(rig))
    builder.Connect(scene_graph.get_query_output_port(), camera.get_geometry_query_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    return camera, camera.GetMyContextFromRoot(context), diagram, context


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
