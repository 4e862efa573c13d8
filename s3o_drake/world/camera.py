"""The overhead camera: its pose, intrinsics, and the map between pixels and the floor."""

import math
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.sensors import CameraInfo

from s3o_drake.world.map import Room
from s3o_drake.world.settings import Camera


@dataclass(frozen=True)
class OverheadCamera:
    """A pinhole camera C above the room's centre, optical axis straight down.

    Its image is oriented like a map: u (columns) grows with world x, v (rows) grows with
    decreasing world y, so north (+y) is at the top of the picture.
    """

    width: int
    height: int
    fov_y: float
    X_WC: RigidTransform

    @property
    def focal(self) -> float:
        """Focal length in pixels (square pixels)."""
        return self.height / 2 / math.tan(self.fov_y / 2)

    def info(self) -> CameraInfo:
        return CameraInfo(width=self.width, height=self.height, fov_y=self.fov_y)

    def pixel_of(self, p_W: np.ndarray) -> np.ndarray:
        """Pixel (u, v) where the world point p_W appears; float, not rounded."""
        p_C = self.X_WC.inverse() @ np.asarray(p_W, dtype=float)
        f = self.focal
        return np.array([self.width / 2 - 0.5 + f * p_C[0] / p_C[2],
                         self.height / 2 - 0.5 + f * p_C[1] / p_C[2]])

    def point_at(self, u: float, v: float, z_W: float) -> np.ndarray:
        """The world point at height z_W seen at pixel (u, v)."""
        depth = self.X_WC.translation()[2] - z_W
        f = self.focal
        p_C = np.array([(u - self.width / 2 + 0.5) * depth / f,
                        (v - self.height / 2 + 0.5) * depth / f, depth])
        return self.X_WC @ p_C

    def floor_extent(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the floor the image spans, edge to edge of its
        outer pixels: looking straight down, the pixels are a uniform grid on the floor,
        so this is the extent to draw the image at (matplotlib's `extent`)."""
        x_min, y_max = self.point_at(-0.5, -0.5, 0.0)[:2]
        x_max, y_min = self.point_at(self.width - 0.5, self.height - 0.5, 0.0)[:2]
        return float(x_min), float(x_max), float(y_min), float(y_max)


def overhead_camera(room: Room, cam: Camera) -> OverheadCamera:
    """The camera that sees the whole room (and the margin) at the settings' resolution."""
    x_min, y_min, x_max, y_max = room.bounds
    span_x = x_max - x_min + 2 * cam.margin
    span_y = y_max - y_min + 2 * cam.margin
    width = math.ceil(span_x * cam.pixels_per_meter)
    height = math.ceil(span_y * cam.pixels_per_meter)
    fov_y = 2 * math.atan(span_y / 2 / cam.height)
    # Camera axes: x_C = x_W, y_C = -y_W (image rows go south), z_C = -z_W (looking down).
    X_WC = RigidTransform(RollPitchYaw(math.pi, 0.0, 0.0),
                          [(x_min + x_max) / 2, (y_min + y_max) / 2, cam.height])
    return OverheadCamera(width=width, height=height, fov_y=fov_y, X_WC=X_WC)


def back_project(camera: OverheadCamera, depth: np.ndarray) -> np.ndarray:
    """World points (H, W, 3) seen at each pixel of a depth image (m along the optical axis).

    Pixels without a return (inf or nan depth) give nan.
    """
    depth = np.where(np.isfinite(depth), depth, np.nan).astype(float)
    v, u = np.mgrid[0:camera.height, 0:camera.width].astype(float)
    f = camera.focal
    p_C = np.stack([(u - camera.width / 2 + 0.5) * depth / f,
                    (v - camera.height / 2 + 0.5) * depth / f, depth], axis=-1)
    R_WC = camera.X_WC.rotation().matrix()
    return p_C @ R_WC.T + camera.X_WC.translation()
