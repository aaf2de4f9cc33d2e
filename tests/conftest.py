"""Fixtures every test file may use: where the repository and the shared mapf-IR data are.

The shared data (real mapf-IR maps, instances and solutions) sits beside the
repository, as ../shared/data/mapf-ir; CI always has it, so its absence fails
loudly instead of skipping tests.
"""
from __future__ import annotations

from pathlib import Path

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
