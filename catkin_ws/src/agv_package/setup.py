"""catkin's view of agv_package: the same source tree the root setup.py installs.

Used by catkin_python_setup() in CMakeLists.txt; do not run it directly.
"""
from __future__ import annotations

from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

setup(
    **generate_distutils_setup(
        packages=find_packages("src"),
        package_dir={"": "src"},
    )
)
