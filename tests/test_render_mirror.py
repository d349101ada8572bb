"""RenderMirror alone: it copies the perception geometry and poses the mirrored frames."""

from __future__ import annotations

import numpy as np
from pydrake.geometry import Box, Role, SceneGraph, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.framework import DiagramBuilder

from legato_drake.systems.render_mirror import RenderMirror


def _scene():
    """A plant with an anchored box, a free ball and a free body whose geometry has no
    perception role; the mirror and its render SceneGraph."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.002), builder)
    plant.RegisterVisualGeometry(plant.world_body(), RigidTransform([0, 0, -0.1]),
                                       Box(1, 1, 0.2), "floor", [0.5, 0.5, 0.5, 1])
    ball = plant.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(0.1, 0.05))
    plant.RegisterVisualGeometry(ball, RigidTransform(), Sphere(0.05), "ball", [1, 1, 1, 1])
    hidden = plant.AddRigidBody("hidden", SpatialInertia.SolidSphereWithMass(0.1, 0.05))
    hidden_geometry = plant.RegisterVisualGeometry(hidden, RigidTransform(), Sphere(0.05),
                                                   "hidden", [1, 1, 1, 1])
    plant.Finalize()
    scene_graph.RemoveRole(plant.get_source_id(), hidden_geometry, Role.kPerception)
    render = builder.AddSystem(SceneGraph())
    mirror = builder.AddSystem(RenderMirror(plant, scene_graph, render))
    return plant, render, mirror


def test_copies_only_the_perception_geometry():
    plant, render, mirror = _scene()
    inspector = render.model_inspector()
    names = sorted(inspector.GetName(g) for g in inspector.GetAllGeometryIds(Role.kPerception))
    assert len(names) == 2 and any("floor" in n for n in names)
    assert any("ball" in n for n in names) and not any("hidden" in n for n in names)
    assert inspector.num_frames() == 2  # the world and the ball's mirror (not the hidden body)


def test_outputs_the_body_poses_for_the_mirrored_frames():
    plant, render, mirror = _scene()
    ball = plant.GetBodyByName("ball")
    X_WB = RigidTransform(RollPitchYaw(0.1, -0.2, 0.3), [0.4, -0.5, 0.6])
    plant_context = plant.CreateDefaultContext()
    plant.SetFreeBodyPose(plant_context, ball, X_WB)
    context = mirror.CreateDefaultContext()
    mirror.get_input_port().FixValue(context, plant.get_body_poses_output_port()
                                     .Eval(plant_context))
    poses = mirror.get_output_port().Eval(context)
    frame = mirror.mirror_frame(plant.GetBodyFrameIdOrThrow(ball.index()))
    assert poses.size() == 1
    np.testing.assert_allclose(poses.value(frame).GetAsMatrix4(), X_WB.GetAsMatrix4(),
                               atol=1e-12)
