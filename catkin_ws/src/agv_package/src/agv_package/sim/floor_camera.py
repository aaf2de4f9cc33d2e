"""Draws what the robot's downward camera sees: the floor and its AprilTags.

Each tag is OpenCV's tag36h11 marker (cv2.aruco DICT_APRILTAG_36h11): an
8 x 8 cell square (6 x 6 data bits inside a black border), `tag_size` metres
across, on a white quiet zone one cell wide, printed on a grey floor. The
camera looks straight down (`camera_model`), so each visible tag is pasted in
with one affine warp; the image gets sensor noise. Only tags near the camera
are drawn, which keeps a frame to a millisecond or two.
"""
from __future__ import annotations

import functools
import math
from typing import List, Optional

import cv2
import numpy as np

from ..camera_model import CameraMount, Intrinsics, floor_to_pixels
from ..geometry import Pose2D
from ..tag_map import TagMap

#: Pixels per marker cell in the source bitmaps (sharp enough for any zoom we use).
CELL_PIXELS = 24
MARKER_CELLS = 8    # 6 data bits + the black border, on each side
QUIET_CELLS = 1     # white margin around the black border
FLOOR_GREY = 150


@functools.lru_cache(maxsize=None)
def marker_bitmap(tag_id: int) -> np.ndarray:
    """The tag36h11 marker `tag_id` with its white quiet zone, uint8, top edge = row 0."""
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    side = MARKER_CELLS * CELL_PIXELS
    if hasattr(cv2.aruco, "generateImageMarker"):  # OpenCV >= 4.7
        marker = cv2.aruco.generateImageMarker(dictionary, tag_id, side)
    else:  # OpenCV 4.2 .. 4.6 (Ubuntu 20.04, Debian 12)
        marker = cv2.aruco.drawMarker(dictionary, tag_id, side)
    # OpenCV draws the 36h11 markers half a turn from AprilTag's own upright tag (measured:
    # the detector's first corner, the tag's bottom-left, comes out top-right); turn it back
    # so that a tag of yaw 0 looks as AprilTag prints it, top edge towards +y.
    marker = np.ascontiguousarray(np.rot90(marker, 2))
    pad = QUIET_CELLS * CELL_PIXELS
    return cv2.copyMakeBorder(marker, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)


class FloorCamera:
    """Renders mono8 frames of the tag floor seen from a robot pose."""

    def __init__(self, tags: TagMap, tag_size: float, mount: CameraMount, width: int,
                 height: int, intrinsics: Intrinsics, noise: float = 2.0,
                 seed: Optional[int] = None) -> None:
        self.tags = tags
        self.tag_size = tag_size
        self.mount = mount
        self.width, self.height = width, height
        self.intrinsics = intrinsics
        self.noise = noise
        self._rng = np.random.default_rng(seed)
        # Sensor grain: one noise field twice the frame, cropped at a random offset per
        # frame (drawing fresh normals for every pixel would cost more than the rest).
        self._grain = np.clip(self._rng.normal(0.0, noise, (2 * height, 2 * width)),
                              -127, 127).astype(np.int16)
        fx, fy = intrinsics[0], intrinsics[1]
        # Floor radius the image can show, plus half a tag: what is worth drawing.
        half_view = math.hypot(width / fx, height / fy) * mount.z / 2.0
        self._reach = half_view + tag_size * (MARKER_CELLS + 2 * QUIET_CELLS) / MARKER_CELLS

    def visible_tags(self, robot: Pose2D) -> List[int]:
        """Ids of the tags close enough to the camera to appear (partly) in a frame."""
        c, s = math.cos(robot.theta), math.sin(robot.theta)
        cam_x = robot.x + c * self.mount.x - s * self.mount.y
        cam_y = robot.y + s * self.mount.x + c * self.mount.y
        return [tag_id for tag_id, place in self.tags.items()
                if math.hypot(place.x - cam_x, place.y - cam_y) <= self._reach]

    def render(self, robot: Pose2D) -> np.ndarray:
        """The camera frame (height x width, uint8) with the robot at `robot` (world metres)."""
        image = np.full((self.height, self.width), FLOOR_GREY, dtype=np.uint8)
        to_pixels = np.vstack([floor_to_pixels(robot, self.mount, self.intrinsics),
                               [0.0, 0.0, 1.0]])
        for tag_id in self.visible_tags(robot):
            place = self.tags.get(tag_id)
            bitmap = marker_bitmap(tag_id)
            metres_per_pixel = self.tag_size / (MARKER_CELLS * CELL_PIXELS)
            centre = (bitmap.shape[0] - 1) / 2.0
            c, s = math.cos(place.yaw), math.sin(place.yaw)
            # Bitmap pixel (col, row) -> floor: rows run down the printed tag, i.e. against
            # the tag's top direction (+y of the floor when yaw = 0).
            to_floor = np.array([
                [c * metres_per_pixel, s * metres_per_pixel,
                 place.x - (c + s) * metres_per_pixel * centre],
                [s * metres_per_pixel, -c * metres_per_pixel,
                 place.y - (s - c) * metres_per_pixel * centre],
                [0.0, 0.0, 1.0]])
            warp = (to_pixels @ to_floor)[:2]
            cv2.warpAffine(bitmap, warp, (self.width, self.height), dst=image,
                           flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_TRANSPARENT)
        if self.noise > 0.0:
            top = int(self._rng.integers(0, self.height))
            left = int(self._rng.integers(0, self.width))
            grain = self._grain[top:top + self.height, left:left + self.width]
            image = np.clip(image + grain, 0, 255).astype(np.uint8)
        return image
