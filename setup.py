"""Installs FleetControl's Python packages and the `fleetctl` command for pip users.

The source trees stay where catkin expects them (catkin_ws/src/<pkg>/src/<pkg>);
PACKAGE_ROOTS maps each top-level package to the folder that holds it, so a new
package is one more line there. `pip install -e ".[test]"` is what
`scripts/ciirc-exec.sh setup` runs.
"""
from __future__ import annotations

import posixpath
import re
from pathlib import Path
from typing import Dict, List

from setuptools import Extension, find_packages, setup

HERE = Path(__file__).resolve().parent

#: Top-level package -> folder (relative to this file) that contains it.
PACKAGE_ROOTS: Dict[str, str] = {
    "fleet_common": "catkin_ws/src/fleet_common/src",
    "fleet_manager": "catkin_ws/src/fleet_manager/src",
    "virtual_fleet": ".",
    "deploy": ".",
    "agv_package": "catkin_ws/src/agv_package/src",
    "fleetctl": ".",
    "console": ".",
    "evaluation": ".",
}

#: Data files shipped inside packages (globs relative to the package folder).
PACKAGE_DATA: Dict[str, List[str]] = {
    "fleet_common": ["lab/*.map", "lab/*.yaml", "lab/*.txt", "tk_colours.txt"],
}


def _packages() -> List[str]:
    found: List[str] = []
    for name, root in PACKAGE_ROOTS.items():
        found += find_packages(root, include=[name, name + ".*"])
    return found


#: C extensions: the solvers' hot loops (fleet_common/planning/_native.c). Optional: where it cannot be built
#: (no compiler or Python headers), pip says so and the Python step, which it mirrors, is used.
EXTENSIONS = [
    Extension("fleet_common.planning._native",
              [f"{PACKAGE_ROOTS['fleet_common']}/fleet_common/planning/_native.c"],
              extra_compile_args=["-O2", "-std=c99"], optional=True),
]


def _version() -> str:
    # One version for the whole product: fleet_common's, which package.xml repeats.
    init = HERE / PACKAGE_ROOTS["fleet_common"] / "fleet_common" / "__init__.py"
    match = re.search(r'^__version__ = "([^"]+)"', init.read_text(encoding="utf-8"), re.M)
    if match is None:
        raise RuntimeError(f"{init}: no __version__ = \"X.Y.Z\" line")
    return match.group(1)


setup(
    name="fleetcontrol",
    version=_version(),
    description="Runs multi-agent path finding plans on a fleet of TurtleBot robots.",
    license="MIT",
    python_requires=">=3.8",
    packages=_packages(),
    package_dir={name: posixpath.normpath(f"{root}/{name}") for name, root in PACKAGE_ROOTS.items()},
    package_data=PACKAGE_DATA,
    ext_modules=EXTENSIONS,
    install_requires=[
        "numpy>=1.24,<3",
        "pyyaml>=6,<7",
        "networkx>=3,<4",
        "Pillow>=9.4,<14",
        "pyzmq>=24,<28",  # >=24: Debian 12's python3-zmq, which ROS nodes import
        "paramiko>=3.4,<5",  # deploy: SSH to the server and the robots
        # sweeps and reports (fleetctl experiment, fleetctl report): tables, plots, clusters
        "pyarrow>=14,<21",  # 21+ need numpy 2; Debian 12 has 1.24
        "matplotlib>=3.7,<3.11",
        "contourpy>=1.2,<1.3.3",  # matplotlib's; <1.3.3 keeps Debian 12's numpy 1.24
        "dask[distributed]>=2024.1,<2027",
    ],
    extras_require={
        # The robot's tag detector and the simulated base's tag drawing (agv_package).
        "robot": ["pupil-apriltags>=1.0.4,<2"],
        "sim": ["pupil-apriltags>=1.0.4,<2", "opencv-python-headless>=4.7,<4.12"],
        "test": [
            "pupil-apriltags>=1.0.4,<2",
            "opencv-python-headless>=4.7,<4.12",  # <4.12: keeps Debian 12's numpy 1.24
            "pytest>=7.4,<9",
            "pytest-xdist>=3.3,<4",  # the suite on two workers (scripts/ciirc-exec.sh test)
            "hypothesis>=6.80,<7",
            "vermin>=1.6,<2",
            "ruff>=0.6,<1",
        ],
    },
    entry_points={"console_scripts": ["fleetctl=fleetctl.cli:entry"]},
)
