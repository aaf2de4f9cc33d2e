"""FleetControl's manager: it connects to the robots (robots are servers, thesis 6.4).

`robot_link.RobotLink` is one robot's connection, `links.LinkSet` runs many in one
poll loop. No rospy here: the manager runs on any lab PC or laptop.
"""
from __future__ import annotations
