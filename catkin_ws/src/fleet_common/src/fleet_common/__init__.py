"""FleetControl's shared core: formats, grid, plans, validation, frames.

Pure Python (numpy, pyyaml); never imports rospy, so the manager, the console,
the tests and the robots all use the same code. Robot-side code: Python 3.8.
"""
from __future__ import annotations

__version__ = "0.1.0"
