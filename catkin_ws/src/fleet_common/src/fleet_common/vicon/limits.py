"""Every bound on what the Vicon path accepts, in one place (to join fleet_common's limits).

A Tracker stream comes from the network: these keep one bad or hostile sender from
making the reader wrong, slow or large.
"""
from __future__ import annotations

#: Tracker's block sizes; a datagram of any other length is refused ("size").
BLOCK_SIZES = (256, 512, 1024)
#: Bytes of an object's name field (NUL-padded UTF-8); robot definitions keep to it.
NAME_BYTES = 24
#: Largest believable coordinate: 1 km from the Vicon origin, in millimetres.
MAX_ABS_MM = 1.0e6
#: A FrameNumber jump larger than this (a minute at Tracker's 100 Hz) is a restart.
MAX_FRAME_GAP = 6000
#: Distinct object names kept; more are dropped ("too-many") so junk cannot fill memory.
MAX_OBJECTS = 1000
#: Lost frame numbers remembered, so that a late arrival is taken off the lost count.
MAX_REMEMBERED_GAPS = 4096
#: Datagrams a reader takes per wake-up at most, so one flood cannot stall the manager.
MAX_DATAGRAMS = 512
