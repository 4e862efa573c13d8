"""The overhead camera's image with chairs drawn on it: the perceived ones, and the true ones
where the picture is about perception."""

from __future__ import annotations

import math

import cv2
import numpy as np

from s3o_drake.belief.chair_perception import RENDER_PIXEL_OFFSET
from s3o_drake.world import furniture as fu
from s3o_drake.world.camera import OverheadCamera


def draw_chairs(camera: OverheadCamera, color: np.ndarray, poses: list[list[float]], *,
                truth: list[list[float]] | None = None) -> np.ndarray:
    """The overhead colour image (RGB uint8) with chair footprints drawn on it.

    `poses` (the perceived chairs) are outlined in green, with a tick from the seat's
    centre in the direction it faces; `truth`, if given, in thin magenta. The outlines are
    drawn at seat height, where the camera sees the chairs.
    """
    image = np.ascontiguousarray(np.asarray(color)[..., :3], dtype=np.uint8).copy()

    def pixels(xy) -> np.ndarray:
        uv = [camera.pixel_of([x, y, fu.CHAIR_SEAT_HEIGHT]) - RENDER_PIXEL_OFFSET
              for x, y in xy]
        return np.round(np.array(uv)).astype(np.int32).reshape(-1, 1, 2)

    layers = [(truth or [], (255, 0, 255), 1), (poses, (0, 200, 0), 2)]
    for chairs, rgb, width in layers:
        for pose in chairs:
            outline = fu.chair_footprint(pose).exterior.coords
            cv2.polylines(image, [pixels(outline)], True, rgb, width, cv2.LINE_AA)
            x, y, yaw = pose
            tick = pixels([(x, y), (x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw))])
            cv2.line(image, tuple(tick[0, 0]), tuple(tick[1, 0]), rgb, width, cv2.LINE_AA)
    return image
