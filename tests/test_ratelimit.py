"""RateLimitedLog: a flood from one peer is one line plus one count per minute, and the
count adds up to what was held back."""
from __future__ import annotations

import itertools
import logging
import re
from typing import List

from hypothesis import given
from hypothesis import strategies as st

from fleet_common.ratelimit import OTHER_PEERS, RateLimitedLog


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.lines: List[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


_names = itertools.count()


def limited(window: float = 60.0, burst: int = 1, max_keys: int = 1024):
    log = logging.getLogger("test_ratelimit.{}".format(next(_names)))
    log.propagate = False
    log.setLevel(logging.DEBUG)
    lines = Lines()
    log.addHandler(lines)
    clock = Clock()
    return RateLimitedLog(log, window, burst, clock, prefix="robot 3: ", max_keys=max_keys), clock, lines


def test_a_flood_is_one_line_then_one_count() -> None:
    rl, clock, lines = limited()
    for i in range(9813):
        clock.now = i * 0.005
        rl.event(logging.WARNING, "10.0.0.66", "refused frames", "refused a frame from %s: %s",
                 "10.0.0.66", "bad JSON")
    assert lines.lines == ["robot 3: refused a frame from 10.0.0.66: bad JSON"]
    clock.now = 60.0
    rl.flush()
    assert lines.lines[1:] == ["robot 3: 9,812 more refused frames from 10.0.0.66 in the last 60 s"]
    rl.flush()  # said once
    assert len(lines.lines) == 2


def test_other_peers_and_a_new_window_are_logged_again() -> None:
    rl, clock, lines = limited()
    assert rl.event(logging.INFO, "a", "x", "first from a")
    assert rl.event(logging.INFO, "b", "x", "first from b")
    assert not rl.event(logging.INFO, "a", "x", "second from a")
    clock.now = 61.0
    assert rl.event(logging.INFO, "a", "x", "a again")  # the count of the old window first
    assert lines.lines == ["robot 3: first from a", "robot 3: first from b",
                           "robot 3: 1 more x from a in the last 60 s", "robot 3: a again"]


def test_many_keys_share_one_window_past_the_cap() -> None:
    rl, clock, lines = limited(max_keys=4)
    for i in range(100):
        rl.event(logging.INFO, "10.0.0.{}".format(i), "refused frames", "from %s", i)
    assert len(lines.lines) == 5  # four keys and "other peers" once
    assert rl.held(OTHER_PEERS) == 95


@given(st.lists(st.tuples(st.sampled_from("abc"), st.floats(0, 5)), max_size=200),
       st.integers(1, 3))
def test_lines_are_bounded_and_the_counts_add_up(events, burst) -> None:
    rl, clock, lines = limited(window=10.0, burst=burst)
    for key, step in events:
        clock.now += step
        rl.event(logging.INFO, key, "events", "event from %s", key)
    clock.now += 100.0
    rl.flush()
    logged = sum(1 for ln in lines.lines if ln.startswith("robot 3: event from"))
    counted = sum(int(m.group(1).replace(",", "")) for m in
                  (re.search(r"(\S+) more events", ln) for ln in lines.lines) if m)
    assert logged + counted == len(events) == rl.events
    windows = clock.now / 10.0 + 1
    assert len(lines.lines) <= 3 * (burst + 1) * windows
