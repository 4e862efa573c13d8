"""GeometryMirror: a perception-only copy of a SceneGraph, for a camera that renders on demand.

A SceneGraph moves the geometry of every render engine it holds whenever its poses are
updated, and the plant's contact query updates them at every simulation step: with the
overhead camera's VTK engine in the simulation's SceneGraph, a quarter of a step went into
moving the robot's geometry in a renderer whose images the planner reads only when it plans.
The camera therefore looks at a second SceneGraph that holds a copy of the perception-role
geometry, whose poses this system computes from the original sources' pose outputs only
when an image is evaluated.
"""

from collections.abc import Sequence

from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    PerceptionProperties,
    Role,
    SceneGraph,
    SourceId,
)
from pydrake.systems.framework import Context, InputPort, LeafSystem


class GeometryMirror(LeafSystem):
    """Copies the perception-role geometry of `original` into `copy` and moves it there.

    At construction every geometry with the perception role in `original` (with its shape,
    pose in its frame and perception properties, render label included) gets a twin in
    `copy`, registered under this system's source: anchored geometry as anchored geometry,
    geometry of a frame of one of `sources` on a twin frame. Geometry registered later is
    not mirrored: construct the mirror once the original is complete.

    Input ports (one per source in `sources`, in order):
        <source name>_pose: FramePoseVector, the source's poses in `original` (connect the
            port that feeds `original.get_source_pose_port(source)`).
    Output ports:
        geometry_pose: FramePoseVector of the twin frames, for
            copy.get_source_pose_port(mirror.source_id).
    """

    def __init__(self, *, original: SceneGraph, copy: SceneGraph, sources: Sequence[SourceId],
                 name: str = "geometry_mirror") -> None:
        super().__init__()
        inspector = original.model_inspector()
        self._source_id = copy.RegisterSource(name)
        world = inspector.world_frame_id()
        for geometry in inspector.GetGeometries(world, Role.kPerception):
            copy.RegisterAnchoredGeometry(self._source_id, _twin(inspector, geometry))
        # (input port, [(original frame id, twin frame id)]) per source
        self._twins: list[tuple[InputPort, list]] = []
        for source in sources:
            pairs = []
            for frame in sorted(inspector.FramesForSource(source), key=lambda f: f.get_value()):
                geometries = inspector.GetGeometries(frame, Role.kPerception)
                if not geometries:
                    continue
                twin = copy.RegisterFrame(self._source_id, GeometryFrame(
                    inspector.GetName(frame), inspector.GetFrameGroup(frame)))
                for geometry in geometries:
                    copy.RegisterGeometry(self._source_id, twin, _twin(inspector, geometry))
                pairs.append((frame, twin))
            port = self.DeclareAbstractInputPort(f"{inspector.GetName(source)}_pose",
                                                 AbstractValue.Make(FramePoseVector()))
            self._twins.append((port, pairs))
        self.DeclareAbstractOutputPort("geometry_pose", lambda: AbstractValue.Make(
            FramePoseVector()), self._calc_geometry_pose)

    @property
    def source_id(self) -> SourceId:
        """The twins' source in the copy."""
        return self._source_id

    def _calc_geometry_pose(self, context: Context, output: AbstractValue) -> None:
        poses = FramePoseVector()
        for port, pairs in self._twins:
            original = port.Eval(context)
            for frame, twin in pairs:
                poses.set_value(twin, original.value(frame))
        output.set_value(poses)


def _twin(inspector, geometry) -> GeometryInstance:
    instance = GeometryInstance(inspector.GetPoseInFrame(geometry), inspector.GetShape(geometry),
                                inspector.GetName(geometry))
    instance.set_perception_properties(
        PerceptionProperties(inspector.GetPerceptionProperties(geometry)))
    return instance

