"""Every ZeroMQ socket of FleetControl, robot side and manager side, in one place.

`fleet_common.wire` is the protocol without I/O (messages, codec, state
tables, the command executor); this package puts it on sockets. Both ends
import it, so the robot runner, the virtual fleet and the manager share one
way of binding, connecting, securing (CurveZMQ) and polling.

    curve_keys       key files: who may drive the robots
    zap              the ZAP handler that admits only the manager key
    peers            peer addresses for the logs; clients the CURVE handshake refused
    robot_endpoint   one robot's command (ROUTER) and feedback (PUB) sockets
    robot_loop       many robot endpoints served from one thread
    robot_link       the manager's connection to one robot (DEALER + SUB), reconnecting
    pose_feedback    the manager's subscription to a robot's pose stream
    links            many robot links polled from one thread (`LinkSet`)
    truth_stream     the virtual fleet's ground truth (PUB), read by the simulated Vicon

Nothing here is imported by `fleet_common` itself or by `fleet_common.wire`:
code that only reads files or plans never needs pyzmq.
"""
from __future__ import annotations
