"""GeometryMirror: a perception-only copy of a SceneGraph, for a camera that renders on demand.

A SceneGraph moves the geometry of every render engine it holds whenever its poses are
updated, and the plant's contact query updates them at every simulation step: with the
overhead camera's VTK engine in the simulation's SceneGraph, a quarter of a step went into
moving the robot's geometry in a renderer whose images the planner reads only when it plans.
The camera therefore looks at a second SceneGraph that holds a copy of the perception-role
geometry (registered by `AddGeometryMirror`), whose poses the GeometryMirror computes from
the original sources' pose outputs only when an image is evaluated.
"""

from collections.abc import Sequence

from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FrameId,
    FramePoseVector,
    GeometryFrame,
    GeometryId,
    GeometryInstance,
    PerceptionProperties,
    Role,
    SceneGraph,
    SceneGraphInspector,
    SourceId,
)
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, LeafSystem

from s3o_drake.world.system_lifetime import weak_callback

#: Per mirrored source: its name, and (original frame id, twin frame id) per frame that has
#: perception geometry.
Twins = Sequence[tuple[str, Sequence[tuple[FrameId, FrameId]]]]


def AddGeometryMirror(builder: DiagramBuilder, *, original: SceneGraph, copy: SceneGraph,
                      sources: Sequence[SourceId],
                      name: str = "geometry_mirror") -> "GeometryMirror":
    """Copies the perception-role geometry of `original` into `copy` and adds the
    GeometryMirror that moves it there to `builder`, named `name`, its geometry_pose
    connected to `copy`; its inputs (one per source) are the caller's to connect.

    Every geometry with the perception role in `original` (with its shape, pose in its
    frame and perception properties, render label included) gets a twin in `copy`,
    registered under a source `name`: anchored geometry as anchored geometry, geometry of
    a frame of one of `sources` on a twin frame. Geometry registered later is not mirrored:
    call it once the original is complete.
    """
    inspector = original.model_inspector()
    source_id = copy.RegisterSource(name)
    world = inspector.world_frame_id()
    for geometry in inspector.GetGeometries(world, Role.kPerception):
        copy.RegisterAnchoredGeometry(source_id, _twin(inspector, geometry))
    twins = []
    for source in sources:
        pairs = []
        for frame in sorted(inspector.FramesForSource(source), key=lambda f: f.get_value()):
            geometries = inspector.GetGeometries(frame, Role.kPerception)
            if not geometries:
                continue
            twin = copy.RegisterFrame(source_id, GeometryFrame(
                inspector.GetName(frame), inspector.GetFrameGroup(frame)))
            for geometry in geometries:
                copy.RegisterGeometry(source_id, twin, _twin(inspector, geometry))
            pairs.append((frame, twin))
        twins.append((inspector.GetName(source), tuple(pairs)))
    mirror = builder.AddNamedSystem(name, GeometryMirror(source_id=source_id, twins=twins))
    builder.Connect(mirror.GetOutputPort("geometry_pose"), copy.get_source_pose_port(source_id))
    return mirror


class GeometryMirror(LeafSystem):
    """Moves the twins of a SceneGraph's perception geometry (`AddGeometryMirror` registers
    them in the copy under `source_id`, and constructs the mirror with the `twins`) where
    the original frames are.

    Input ports (one per source in `twins`, in order):
        <source name>_pose: FramePoseVector, the source's poses in the original (connect
            the port that feeds the original's `get_source_pose_port(source)`).
    Output ports:
        geometry_pose: FramePoseVector of the twin frames, for
            copy.get_source_pose_port(mirror.source_id).
    """

    def __init__(self, *, source_id: SourceId, twins: Twins) -> None:
        super().__init__()
        self._source_id = source_id
        # (input port, [(original frame id, twin frame id)]) per source
        self._twins: list[tuple[InputPort, tuple[tuple[FrameId, FrameId], ...]]] = []
        for source_name, pairs in twins:
            port = self.DeclareAbstractInputPort(f"{source_name}_pose",
                                                 AbstractValue.Make(FramePoseVector()))
            self._twins.append((port, tuple(pairs)))
        self.DeclareAbstractOutputPort("geometry_pose", lambda: AbstractValue.Make(
            FramePoseVector()), weak_callback(self._calc_geometry_pose))

    @property
    def source_id(self) -> SourceId:
        """The twins' source in the copy."""
        return self._source_id

    def twin(self, frame: FrameId) -> FrameId:
        """The copy's frame that follows the original's `frame` (one with perception
        geometry); KeyError for another."""
        for _, pairs in self._twins:
            for original, twin in pairs:
                if original == frame:
                    return twin
        raise KeyError(f"frame {frame} has no twin: it holds no perception geometry")

    def _calc_geometry_pose(self, context: Context, output: AbstractValue) -> None:
        poses = FramePoseVector()
        for port, pairs in self._twins:
            original = port.Eval(context)
            for frame, twin in pairs:
                poses.set_value(twin, original.value(frame))
        output.set_value(poses)


def _twin(inspector: SceneGraphInspector, geometry: GeometryId) -> GeometryInstance:
    instance = GeometryInstance(inspector.GetPoseInFrame(geometry), inspector.GetShape(geometry),
                                inspector.GetName(geometry))
    instance.set_perception_properties(
        PerceptionProperties(inspector.GetPerceptionProperties(geometry)))
    return instance
