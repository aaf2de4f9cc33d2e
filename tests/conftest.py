"""Fixtures every test file may use: where the repository and the shared mapf-IR data are.

The shared data (real mapf-IR maps, instances and solutions) sits beside the
repository, as ../shared/data/mapf-ir; CI always has it, so its absence fails
loudly instead of skipping tests.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterator

import pytest
from hypothesis import settings

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "data" / "mapf-ir"

# CI machines have two busy cores: a per-example deadline would make property tests flaky.
settings.register_profile("fleetcontrol", deadline=None)
settings.load_profile("fleetcontrol")


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The repository's top folder (where setup.py is)."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """../shared/data/mapf-ir beside the repository: maps/, instances/, solutions/."""
    if not (SHARED_DATA / "maps").is_dir():
        pytest.fail(
            f"shared mapf-IR data not found at {SHARED_DATA}: the tests expect the"
            " project's shared/ folder beside the repository (CI always has it)",
            pytrace=False,
        )
    return SHARED_DATA


@pytest.fixture(scope="session")
def xvfb() -> Iterator[str]:
    """One private Xvfb for the whole session: a Tk interpreter keeps its X connection after its
    windows are gone, and Tk exits the process when that connection breaks, so the server must
    outlive every Tk window of the session."""
    from console.xvfb import Xvfb

    server = Xvfb.start(1600, 1024)
    try:
        yield server.display
    finally:
        server.stop()


@pytest.fixture(scope="module")
def display(xvfb: str) -> Iterator[str]:
    """The session's Xvfb as DISPLAY while the module runs (for its Tk windows)."""
    before = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = xvfb
    try:
        yield xvfb
    finally:
        if before is None:
            os.environ.pop("DISPLAY", None)
        else:
            os.environ["DISPLAY"] = before
