"""A render-only copy of the scene, so that cameras cost nothing between their frames.

A SceneGraph that owns a render engine pushes every pose update (each physics step, for
contact) into the renderer too. The cameras render at 10 Hz and the plant steps at 500 Hz,
so the project renders from a second SceneGraph that holds only the perception geometry and
learns the body poses only when a camera asks for them.
"""

from __future__ import annotations

from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FrameId,
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    LightParameter,
    MakeRenderEngineVtk,
    RenderEngineVtkParams,
    Role,
    SceneGraph,
)
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem


class RenderMirror(LeafSystem):
    """Mirrors the plant's perception geometry into a render-only SceneGraph.

    At construction it copies every geometry that has the perception role in the plant's
    SceneGraph into ``render_scene_graph`` (anchored geometry stays anchored, geometry on a
    body gets a frame of its own). Its output gives those frames the bodies' poses.

    Input ports:
        body_poses: the plant's body poses (``plant.get_body_poses_output_port()``).

    Output ports:
        frame_poses (FramePoseVector): connect to the render SceneGraph's source pose port.
    """

    def __init__(self, plant: MultibodyPlant, scene_graph: SceneGraph,
                 render_scene_graph: SceneGraph):
        super().__init__()
        self._source = render_scene_graph.RegisterSource("render_mirror")
        inspector = scene_graph.model_inspector()
        self._frames: dict[FrameId, tuple[FrameId, int]] = {}
        """Frame id in the plant's SceneGraph -> (frame id in the render one, body index)."""
        for geometry_id in inspector.GetAllGeometryIds(Role.kPerception):
            frame = inspector.GetFrameId(geometry_id)
            instance = GeometryInstance(inspector.GetPoseInFrame(geometry_id),
                                        inspector.GetShape(geometry_id).Clone(),
                                        inspector.GetName(geometry_id))
            if frame == inspector.world_frame_id():
                new_id = render_scene_graph.RegisterAnchoredGeometry(self._source, instance)
            else:
                if frame not in self._frames:
                    body = plant.GetBodyFromFrameId(frame)
                    mirror = render_scene_graph.RegisterFrame(
                        self._source, GeometryFrame(inspector.GetName(frame)))
                    self._frames[frame] = (mirror, int(body.index()))
                new_id = render_scene_graph.RegisterGeometry(
                    self._source, self._frames[frame][0], instance)
            render_scene_graph.AssignRole(self._source, new_id,
                                          inspector.GetPerceptionProperties(geometry_id))
        self._body_poses = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()]))
        self.DeclareAbstractOutputPort(
            "frame_poses", lambda: AbstractValue.Make(FramePoseVector()), self._calc,
            {self.all_input_ports_ticket()})

    @property
    def source_id(self):
        """The geometry source this system registered in the render SceneGraph."""
        return self._source

    def mirror_frame(self, frame: FrameId) -> FrameId:
        """The render SceneGraph's frame that mirrors the plant SceneGraph's ``frame``."""
        return self._frames[frame][0]

    def _calc(self, context: Context, output: AbstractValue) -> None:
        poses = self._body_poses.Eval(context)
        vector = output.get_mutable_value()
        vector.clear()
        for mirror, body in self._frames.values():
            vector.set_value(mirror, poses[body])


def render_engine_params() -> RenderEngineVtkParams:
    """VTK settings: a ceiling light plus a dim headlight, so that the table top (seen at a
    grazing angle) is not black as it is under Drake's default headlight alone."""
    return RenderEngineVtkParams(lights=[
        LightParameter(type="directional", frame="world", direction=[0.3, 0.2, -1.0],
                       intensity=0.9),
        LightParameter(type="directional", frame="camera", direction=[0.0, 0.0, 1.0],
                       intensity=0.35),
    ])


def add_render_scene(builder: DiagramBuilder, plant: MultibodyPlant, scene_graph: SceneGraph,
                     renderer: str) -> tuple[SceneGraph, RenderMirror]:
    """Adds a render-only SceneGraph (with a VTK engine named ``renderer``) fed by a mirror."""
    render_scene_graph = builder.AddNamedSystem("render_scene_graph", SceneGraph())
    render_scene_graph.AddRenderer(renderer, MakeRenderEngineVtk(render_engine_params()))
    mirror = builder.AddNamedSystem("render_mirror",
                                    RenderMirror(plant, scene_graph, render_scene_graph))
    builder.Connect(plant.get_body_poses_output_port(), mirror.get_input_port())
    builder.Connect(mirror.get_output_port(),
                    render_scene_graph.get_source_pose_port(mirror.source_id))
    return render_scene_graph, mirror
