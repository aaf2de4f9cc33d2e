"""sensor_msgs/Image bytes -> a grey numpy frame, without cv_bridge (not in Debian's ROS).

Only the fields of the message are used (encoding, height, width, step, data),
so this is tested without ROS. Colour frames are turned grey with the usual
luma weights; a frame in an encoding we do not read raises `ValueError`
naming the ones we do.
"""
from __future__ import annotations

import numpy as np

_CHANNELS = {"mono8": 1, "8UC1": 1, "rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}
#: Luma weights (ITU-R BT.601) for red, green, blue.
_LUMA = np.array([0.299, 0.587, 0.114])


def supported_encodings() -> str:
    return ", ".join(sorted(_CHANNELS))


def image_to_grey(encoding: str, height: int, width: int, step: int, data: bytes) -> np.ndarray:
    """The frame as a (height, width) uint8 array (a view of `data` for mono8)."""
    channels = _CHANNELS.get(encoding)
    if channels is None:
        raise ValueError("camera frames in encoding {!r} are not supported; use one of {}".format(
            encoding, supported_encodings()))
    if step < width * channels or len(data) < step * height:
        raise ValueError("image of {}x{} {} needs step >= {} and {} bytes, got step {} and {}"
                         .format(width, height, encoding, width * channels,
                                 width * channels * height, step, len(data)))
    rows = np.frombuffer(data, dtype=np.uint8, count=step * height).reshape(height, step)
    pixels = rows[:, :width * channels].reshape(height, width, channels)
    if channels == 1:
        return pixels[:, :, 0]
    colour = pixels[:, :, :3].astype(np.float32)
    if encoding.startswith("bgr"):
        colour = colour[:, :, ::-1]
    return np.clip(colour @ _LUMA + 0.5, 0, 255).astype(np.uint8)
