"""Camera frame in, robot pose fixes out: AprilTag detection (pupil-apriltags) on the floor.

`TagLocalizer.locate(image, intrinsics)` detects tag36h11 tags in a mono8
frame, estimates each tag's pose with the camera intrinsics (CameraInfo's K;
the frame must be rectified) and the printed tag size, and turns every
plausible one into a robot pose via `tag_pose`. Detections it cannot use are
returned with the reason, for the node to log: unknown ids, weak decodes,
and poses that put the robot off the floor.
"""
from __future__ import annotations

import functools
import threading
from typing import Any, List, NamedTuple, Tuple

import numpy as np

from .camera_model import CameraMount, Intrinsics
from .geometry import Pose2D
from .tag_map import TagMap
from .tag_pose import TagObservation, robot_pose_from_tag

#: How far (metres) a fix may put the robot origin above or below the floor.
MAX_HEIGHT_ERROR = 0.05


@functools.lru_cache(maxsize=None)
def _shared_detector(quad_decimate: float, threads: int) -> Tuple[Any, threading.Lock]:
    """One detector per setting, kept for the life of the process, with a lock for it.

    pupil-apriltags frees a detector's tag family before the detector itself, and the
    detector then reads the freed family: deleting a Detector can crash the process
    (pupil-labs/apriltags issues 34 and 46). Detectors made here are never deleted.
    """
    import pupil_apriltags  # a compiled extension: imported where it is used

    detector = pupil_apriltags.Detector(families="tag36h11", nthreads=threads,
                                        quad_decimate=quad_decimate)
    return detector, threading.Lock()


class TagFix(NamedTuple):
    """Where one tag says the robot is (world frame)."""

    tag_id: int
    pose: Pose2D
    decision_margin: float


class Located(NamedTuple):
    fixes: List[TagFix]
    rejected: List[Tuple[int, str]]  # (tag id, why)


class TagLocalizer:
    """Detects floor tags and converts them to robot poses."""

    def __init__(self, tags: TagMap, tag_size: float, mount: CameraMount,
                 quad_decimate: float = 2.0, min_decision_margin: float = 0.0,
                 max_hamming: int = 0, threads: int = 1) -> None:
        self.tags = tags
        self.tag_size = tag_size
        self.mount = mount
        self.min_decision_margin = min_decision_margin
        self.max_hamming = max_hamming
        self._detector, self._detector_lock = _shared_detector(float(quad_decimate), threads)

    def observe(self, image: np.ndarray, intrinsics: Intrinsics) -> List[TagObservation]:
        """Every tag36h11 detection in `image` with its pose in the camera frame."""
        if image.dtype != np.uint8 or image.ndim != 2:
            raise ValueError("expected a mono8 image (2-D uint8 array), got {} {}".format(
                image.dtype, image.shape))
        with self._detector_lock:
            found = self._detector.detect(np.ascontiguousarray(image), estimate_tag_pose=True,
                                          camera_params=tuple(float(v) for v in intrinsics),
                                          tag_size=self.tag_size)
        return [TagObservation(int(d.tag_id), np.asarray(d.pose_R), np.asarray(d.pose_t),
                               float(d.decision_margin), int(d.hamming)) for d in found]

    def locate(self, image: np.ndarray, intrinsics: Intrinsics) -> Located:
        fixes: List[TagFix] = []
        rejected: List[Tuple[int, str]] = []
        for seen in self.observe(image, intrinsics):
            place = self.tags.get(seen.tag_id)
            if place is None:
                rejected.append((seen.tag_id, "not in the tag map ({})".format(self.tags.source)))
                continue
            if seen.hamming > self.max_hamming:
                rejected.append((seen.tag_id, "{} bit errors corrected (at most {})".format(
                    seen.hamming, self.max_hamming)))
                continue
            if seen.decision_margin < self.min_decision_margin:
                rejected.append((seen.tag_id, "decision margin {:.0f} below {:.0f}".format(
                    seen.decision_margin, self.min_decision_margin)))
                continue
            pose, height = robot_pose_from_tag(seen, place, self.mount)
            if abs(height) > MAX_HEIGHT_ERROR:
                rejected.append((seen.tag_id, "puts the robot {:.2f} m off the floor: check "
                                 "tag_size, camera mount and intrinsics".format(height)))
                continue
            fixes.append(TagFix(seen.tag_id, pose, seen.decision_margin))
        return Located(fixes, rejected)
