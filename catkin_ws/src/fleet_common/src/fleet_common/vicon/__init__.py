"""The Vicon motion-capture system, as data: Tracker's UDP packets, frames, calibration.

- `packet`: the "UDP Object Stream" layout; `decode_packet` (total) and `encode_frame`.
- `stream`: `ViconStream`, packets -> per-object last sighting, frame, receive time,
  counters (lost frames, refused packets by cause).
- `base_grid`: Vicon millimetres <-> base-grid cells through the frames file.
- `calibration`: the vicon -> base similarity from robots on known cells.

Its bounds (block sizes, name bytes, frame gaps, ...) are `fleet_common.limits.VICON_*`.

No sockets here: the manager's `fleet_manager.vicon_provider` owns the UDP socket,
`virtual_fleet.vicon_tracker` plays Tracker for virtual runs.
"""
from __future__ import annotations

from .packet import (BLOCK_SIZES, ViconObject, ViconPacket, ViconPacketError, decode_packet,
                     encode_frame)
from .stream import Sighting, ViconCounters, ViconStream

__all__ = ["BLOCK_SIZES", "ViconObject", "ViconPacket", "ViconPacketError", "decode_packet",
           "encode_frame", "Sighting", "ViconCounters", "ViconStream"]
