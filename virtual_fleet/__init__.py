"""Virtual robots without ROS, on the same ports and protocol as the real ones (thesis 4.4).

`kinematics.VirtualNavigator` moves a robot kinematically (turn, then drive) in
scaled time, `delays` describes what may go wrong with a move, and `fleet`
serves one `RobotEndpoint` per robot definition from a single event loop, so
300 robots run in one process. `fleetctl virtual-fleet` starts it.
"""
from __future__ import annotations
