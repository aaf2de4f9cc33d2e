"""FleetControl's manager: it drives the fleet through a plan (thesis 5.3).

Robots are servers and the manager connects to them (thesis 6.4) through
`fleet_common.transport` (robot links, one poll loop for the fleet). No
rospy here: the manager runs on any lab PC.
"""
from __future__ import annotations
