"""FleetControl's robot side: the runner, AprilTag grid navigation and a simulated base.

Pure modules (numpy, pupil-apriltags, OpenCV for the simulator; no rospy):
`geometry`, `grid_frame` (base cells <-> robot metres, the only such
conversion on the robot), `camera_model`, `tag_map`, `tag_pose`,
`tag_localizer`, `pose_fusion`, `motion`, `navigator`, `wire_navigator`,
`settings`, `runner_settings`, `image_convert`, and `sim/`. The ROS layer is
thin: `ros_messages`, `ros_navigator`, `runner_node`, `sim_node`.
Robot-side code: Python 3.8 (ROS Noetic).
"""
from __future__ import annotations
