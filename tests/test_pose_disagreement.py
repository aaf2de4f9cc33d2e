"""The disagreement detector: a lost robot is reported once, with hysteresis."""
from __future__ import annotations

from typing import List, Optional

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet_manager.pose_disagreement import DisagreementDetector, DisagreementEvent
from fleet_common.wire.messages import Pose

HOME = Pose(3.0, 4.0, 0.0)


def run(detector: DisagreementDetector, offsets: List[float], dt: float = 0.05,
        skew: float = 0.0) -> List[Optional[DisagreementEvent]]:
    """Feed one sample every `dt` s with Vicon `offset` cells to the right of the robot."""
    out = []
    for i, off in enumerate(offsets):
        now = i * dt
        out.append(detector.update(7, HOME, now, Pose(HOME.x + off, HOME.y, 0.0), now - skew,
                                   now))
    return out


def test_a_robot_that_drifts_away_is_reported_once_after_the_hold() -> None:
    d = DisagreementDetector(threshold=0.5, hold=0.2)
    events = run(d, [0.0] * 5 + [0.8] * 20)
    fired = [(i, e) for i, e in enumerate(events) if e is not None]
    assert len(fired) == 1
    i, event = fired[0]
    assert i == 5 + 4  # 0.2 s of samples 0.05 s apart after the first one above
    assert event.disagree and event.robot_id == 7 and event.distance == pytest.approx(0.8)
    assert "is it lost?" in event.describe()
    assert d.disagreeing() == {7}


def test_it_agrees_again_only_below_the_lower_threshold() -> None:
    d = DisagreementDetector(threshold=0.5, clear_below=0.3, hold=0.0)
    events = run(d, [0.8, 0.45, 0.35, 0.45, 0.2, 0.45, 0.6])
    kinds = [None if e is None else e.disagree for e in events]
    assert kinds == [True, None, None, None, False, None, True]


def test_one_noisy_sample_raises_nothing() -> None:
    d = DisagreementDetector(threshold=0.5, hold=0.2)
    assert all(e is None for e in run(d, [0.0, 0.0, 3.0, 0.0, 0.0, 3.0, 3.0, 0.0]))


def test_poses_received_too_far_apart_are_not_compared() -> None:
    d = DisagreementDetector(threshold=0.5, hold=0.0, max_skew=0.25)
    assert all(e is None for e in run(d, [2.0] * 10, skew=0.3))
    assert run(d, [2.0], skew=0.2)[0] is not None


def test_a_gap_in_the_comparisons_does_not_restart_the_hold() -> None:
    """The robot's own poses come late now and then (a loaded PC, a jittery link): the samples
    that can be compared are all far apart, and the robot is reported after the hold."""
    d = DisagreementDetector(threshold=0.5, hold=0.2, max_skew=0.25)
    fired = []
    for i in range(12):  # one sample every 0.05 s; every third one's own pose is 0.3 s old
        now = i * 0.05
        own_time = now - (0.3 if i % 3 == 2 else 0.0)
        fired.append(d.update(7, HOME, own_time, Pose(HOME.x + 2.0, HOME.y, 0.0), now, now))
    assert [i for i, e in enumerate(fired) if e is not None] == [4]  # 0.2 s after the first, as without gaps
    # a sample back under the threshold does restart it
    d = DisagreementDetector(threshold=0.5, hold=0.2)
    assert all(e is None for e in run(d, [2.0, 2.0, 2.0, 0.0, 2.0, 2.0, 2.0, 2.0]))


def test_forget_starts_afresh() -> None:
    d = DisagreementDetector(threshold=0.5, hold=0.0)
    run(d, [1.0])
    d.forget(7)
    assert d.disagreeing() == set()
    assert run(d, [0.0])[0] is None


@given(st.lists(st.floats(0.0, 2.0), max_size=80), st.floats(0.0, 0.3))
def test_events_alternate_and_match_the_distances(offsets: List[float], hold: float) -> None:
    d = DisagreementDetector(threshold=0.5, hold=hold)
    fired = [e for e in run(d, offsets) if e is not None]
    assert [e.disagree for e in fired] == [i % 2 == 0 for i in range(len(fired))]
    for e in fired:
        assert (e.distance > 0.5) if e.disagree else (e.distance < d.clear_below)
    if max(offsets, default=0.0) <= 0.5:
        assert fired == []
