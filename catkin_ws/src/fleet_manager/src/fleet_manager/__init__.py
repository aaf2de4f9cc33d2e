"""FleetControl's manager: it connects to the robots (robots are servers, thesis 6.4).

`robot_link.RobotLink` is one robot's connection (reporting `link_events`),
`pose_feedback` its subscription to the robot's poses, `links.LinkSet` runs
many links in one poll loop. No rospy here: the manager runs on any lab PC.
"""
from __future__ import annotations
