"""BaseScanner: the base's planar scanner, as a mobile base's safety and localisation laser
scanners see the room: the walls and the legs of the tables and chairs, at SCAN_HEIGHT.

Drake has no laser scanner; here it is four depth cameras (`RgbdSensor`, rendered by VTK),
one at the middle of each side of the footprint, SIDE_OFFSET outside it and looking out,
each a row of SCAN_PIXELS pixels over SCAN_FOV: a row of a depth image is a scan.
They ride the base in the overhead camera's mirror of the scene (world/geometry_mirror.py)
and render only when the scan is read. `scan_points` (plain Python) turns their rows into
points in the base's frame; `BaseScanner` is its adapter.
"""

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F

from s3o_drake.world.system_lifetime import weak_callback

SCAN_HEIGHT = 0.2
"""The scan's height above the floor (m): below the chairs' seats and the tables' tops, where
only their legs and the walls stand."""
SCAN_PIXELS = 160
"""Returns per camera: 0.6 degrees apart over SCAN_FOV."""
SCAN_FOV = math.radians(100.0)
"""Each camera's horizontal field of view: four overlap at the footprint's corners."""
SCAN_RANGE = (0.05, 10.0)
"""The nearest and furthest (m) a return is seen at, along a camera's axis."""
SIDE_OFFSET = 0.02
"""How far outside the footprint's sides (m) the cameras sit: they see the room, not the
base."""


@dataclass(frozen=True)
class BaseScan:
    """The scanner's returns: where it saw the walls and the legs of what stands on the
    floor, as points (x, y) in the base's frame (m), at SCAN_HEIGHT; nothing where it saw
    nothing within SCAN_RANGE. Immutable: Drake copies port values."""

    points_B: tuple[tuple[float, float], ...] = ()  # noqa: N815 (monogram notation)


def scanner_mounts(*, base_length: float, base_width: float) -> list[RigidTransform]:
    """X_BC of the four cameras (front, left, back, right): at SCAN_HEIGHT, at the middle
    of each side of a base_length x base_width footprint, looking out (a camera's z is its
    axis, x to its right, y down)."""
    mounts = []
    for i, half in enumerate((base_length / 2, base_width / 2) * 2):
        heading = i * math.pi / 2
        ahead = np.array([math.cos(heading), math.sin(heading), 0.0])
        right = np.array([math.sin(heading), -math.cos(heading), 0.0])
        R_BC = RotationMatrix(np.column_stack([right, [0.0, 0.0, -1.0], ahead]))
        mounts.append(RigidTransform(R_BC, (half + SIDE_OFFSET) * ahead
                                     + [0.0, 0.0, SCAN_HEIGHT]))
    return mounts


def scanner_info() -> CameraInfo:
    """A camera of the scanner: SCAN_PIXELS over SCAN_FOV, and two rows, half a pixel
    above and below its axis (Drake's cameras have their centre inside the image, and a
    row is a pixel's centre): 0.4 degrees, 3.7 cm at 5 m, which a scan of legs and walls
    does not see."""
    focal = (SCAN_PIXELS / 2) / math.tan(SCAN_FOV / 2)
    return CameraInfo(width=SCAN_PIXELS, height=2, focal_x=focal, focal_y=focal,
                      center_x=(SCAN_PIXELS - 1) / 2, center_y=0.5)


def scan_points(rows: Sequence[np.ndarray], mounts: Sequence[RigidTransform],
                info: CameraInfo) -> np.ndarray:
    """The returns of depth rows `rows` (one per camera, depth along the camera's axis, m)
    from cameras at `mounts` (X_BC) as points (x, y) in the base's frame, (N, 2); pixels
    that saw nothing within SCAN_RANGE are left out."""
    # Drake's renderer samples column u at u + 0.5 of the intrinsics' coordinates: with
    # it, a scan rendered in the restaurant falls on the room's legs and walls to 0.01 mm
    # (rms); at u, every return turned by 4 mrad.
    u = np.arange(info.width()) + 0.5
    slope = (u - info.center_x()) / info.focal_x()
    points = []
    for depth, X_BC in zip(rows, mounts, strict=True):
        depth = np.asarray(depth, dtype=float).reshape(-1)
        seen = np.isfinite(depth) & (depth > SCAN_RANGE[0]) & (depth < SCAN_RANGE[1])
        p_C = np.vstack([depth[seen] * slope[seen], np.zeros(seen.sum()), depth[seen]])
        points.append((X_BC.rotation().matrix() @ p_C).T[:, :2] + X_BC.translation()[:2])
    return np.concatenate(points) if points else np.zeros((0, 2))


class BaseScanner(LeafSystem):
    """The scan of the four cameras at `mounts` (X_BC), each of `info`.

    Input ports:
        depth_0 ... depth_3: ImageDepth32F, the cameras' depth rows (front, left, back,
            right).
    Output ports:
        base_scan: abstract BaseScan, their returns in the base's frame.
    """

    def __init__(self, *, mounts: Sequence[RigidTransform], info: CameraInfo) -> None:
        super().__init__()
        self._mounts = list(mounts)
        self._info = info
        self._depth = [self.DeclareAbstractInputPort(f"depth_{i}",
                                                     AbstractValue.Make(ImageDepth32F()))
                       for i in range(len(self._mounts))]
        self.DeclareAbstractOutputPort("base_scan", lambda: AbstractValue.Make(BaseScan()),
                                       weak_callback(self._calc_scan))

    def _calc_scan(self, context: Context, output: AbstractValue) -> None:
        rows = [np.array(port.Eval(context).data, copy=True)[0, :, 0] for port in self._depth]
        points = scan_points(rows, self._mounts, self._info)
        output.set_value(BaseScan(tuple((float(x), float(y)) for x, y in points)))
