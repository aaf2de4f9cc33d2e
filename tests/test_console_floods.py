"""A console that floods the manager costs a few log lines, a few records and no extra States.

A live manager on 127.0.0.1 (`tests/floods.py`): 10,000 frames that are no
console message, then 10,000 requests it refuses, from one console, while
another watches. The manager answers them all; its log grows by fewer than
100 lines, its run log by less than 100 KB, and neither console gets more
States a second than the manager's limit (`--state-max-rate`, 50).
"""
from __future__ import annotations

import time
from pathlib import Path

import pytest

from fleet_common.lab import lab_instance_path
from floods import flood
from live import fleet_definitions, start_manager

pytestmark = pytest.mark.slow


def test_ten_thousand_bad_frames_and_refused_requests_cost_almost_nothing(tmp_path: Path) -> None:
    definitions, _, port = fleet_definitions(tmp_path, 5)
    manager = start_manager(tmp_path, lab_instance_path(), definitions, port, "--log", tmp_path / "runs",
                            "--state-max-rate", "50")
    try:
        manager.wait_line(r"^manager: ")
        deadline = time.monotonic() + 30
        while not list((tmp_path / "runs").glob("*/events.jsonl")):
            assert time.monotonic() < deadline, "no run folder"
            time.sleep(0.05)
        events = next((tmp_path / "runs").glob("*/events.jsonl"))
        figures = flood(port, manager.log, events, garbage=10_000, refused=10_000)
    finally:
        manager.stop()
    assert figures.answers >= 10_000  # it served the flood (some answers drop from a full queue)
    assert figures.log_lines < 100, manager.tail(20)
    assert figures.run_log_bytes < 100_000
    for states in (figures.states_watcher, figures.states_flooder):
        assert states <= 50 * figures.seconds + 2, figures.lines()
    records = events.read_text().splitlines()
    assert sum('"k":"operator"' in r for r in records) <= 2  # the first refusal, not 10,000
