"""Random operator sessions through the real chain (tests/live_sessions.py): processes, sockets,
a manager killed and started again, power cuts, judged by the virtual fleet's ground truth. Three
seeds here (about 30 s each); `bench/live_sessions.py` runs more."""
from __future__ import annotations

from pathlib import Path

import pytest

from live_sessions import live_session

pytestmark = pytest.mark.slow


# 3: a manager restart; 4: one robot's power cut under the LoRR delays, then the fleet's; 8: one robot's
# power cut, the fleet's and a manager restart
@pytest.mark.parametrize("seed", [3, 4, 8])
def test_a_random_live_session_ends_done_every_robot_home_and_safe(tmp_path: Path, seed: int) -> None:
    found = live_session(seed, tmp_path)
    assert not found.problems, "{}\n{}".format("; ".join(found.problems), "\n".join(map(str, found.log)))
    assert any(action == "start" and ok for _, action, _, ok, _ in found.log)  # the session did drive
