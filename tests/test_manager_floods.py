"""Refused requests and hellos from a console, in memory: what they cost in States and records.

A refused request gets its answer and nothing else: no State, and a record
only for the first refusal of that console in a minute (then one `refused`
record with the count). However a console asks (hellos, accepted requests),
it never gets States faster than the manager's rate.
"""
from __future__ import annotations

from fleet_common.control import codec
from fleet_common.control import messages as m
from fleet_common.lab import lab_instance_path
from fleet_common.plan_loading import load_plan
from fleet_manager.refusals import RefusedRequests
from fleet_manager.settings import ManagerSettings
from memory_fleet import MemoryFleet, lab_fleet


def fleet(rate: float = 50.0) -> MemoryFleet:
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    return MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=0.5, state_max_rate=rate))


def test_refused_requests_send_no_state_and_are_recorded_once_a_minute_then_counted():
    f = fleet()
    flooder, watcher = f.console("flooder"), f.console("watcher")
    f.link_up()
    f.advance(0.5)
    states = (len(flooder.states), len(watcher.states))
    records = len(f.records)
    for _ in range(1000):  # 10 ms apart, nothing else running: a State would be due each time
        f.clock.t += 0.01
        assert not f.ask(flooder, "disable", robot=99999).ok
    assert (len(flooder.states), len(watcher.states)) == states
    operator = [r for r in f.kinds("operator")]
    assert len(operator) == 1 and "not in this run" in operator[0]["reason"]
    assert len(f.records) - records <= 2
    f.advance(61.0)
    held = f.kinds("refused")
    assert [(r["console"], r["requests"]) for r in held] == [("flooder", 999)]


def test_no_console_gets_states_faster_than_the_rate_however_it_asks():
    f = fleet(rate=10.0)
    ops, watcher = f.console("ops"), f.console("watcher")
    f.link_up()
    f.advance(0.5)
    before = {c.name: len(c.states) for c in (ops, watcher)}
    start = f.now
    for i in range(200):  # accepted requests and hellos, 200 in 2 s
        f.ask(ops, "strategy", name="adg" if i % 2 else "step")
        f.core.console_frame(ops.peer, codec.encode(m.Hello("ops")), f.now)
        f.pump()
        f.clock.t += 0.01
    seconds = f.now - start
    for console in (ops, watcher):
        got = len(console.states) - before[console.name]
        assert 0 < got <= 10.0 * seconds + 1, (console.name, got, seconds)
    # and the run's setup (a whole plan) went to the hello-sayer at most once a second
    setups = sum(1 for x in ops.received if isinstance(x, m.RunSetup))
    assert setups <= seconds + 2


def test_each_console_is_paced_on_its_own():
    from fleet_common.control.desk import ControlDesk

    desk = ControlDesk("s", 0.0)
    for peer, name in ((b"a", "a"), (b"b", "b")):
        desk.receive(peer, codec.encode(m.Hello(name)), 0.0)
    state = m.Heartbeat()  # any message: the desk paces what it is given
    assert [p for p, _ in desk.states(state, 0.00, 0.1, only=b"a")] == [b"a"]
    assert [p for p, _ in desk.states(state, 0.05, 0.1)] == [b"b"]  # a had one 50 ms ago
    assert [p for p, _ in desk.states(state, 0.10, 0.1)] == [b"a"]
    assert desk.states(state, 0.12, 0.1) == [] and not desk.state_due(0.12, 0.1)
    assert [p for p, _ in desk.states(state, 0.15, 0.1)] == [b"b"]


def test_refusal_counts_per_console_and_window():
    counts = RefusedRequests(window=60.0)
    assert counts.first(b"a", "ops", 0.0) and not counts.first(b"a", "ops", 1.0)
    assert counts.first(b"b", "other", 2.0)  # another console has its own first
    assert not counts.first(b"a", "ops", 30.0)
    assert counts.due(59.0) == []
    assert counts.first(b"a", "ops", 61.0)  # a new window: its first is recorded again
    assert [(h.console, h.requests) for h in counts.due(61.0)] == [("ops", 2)]
    assert counts.due(200.0) == []  # "b" had nothing held back


def test_a_console_may_act_again_on_its_own_change_before_its_state_arrives():
    """States keep to the rate, so a console that just switched the strategy may not have seen
    it yet: its next request still goes ahead (it knows what it did), another console's not."""
    f = fleet(rate=1.0)
    ops, other = f.console("ops"), f.console("other")
    f.link_up()
    f.advance(0.5)
    looked = max(ops.version, other.version)
    assert f.ask(ops, "strategy", based_on=looked, name="step").ok
    assert f.ask(ops, "strategy", based_on=looked, name="adg").ok
    refused = f.ask(other, "strategy", based_on=looked, name="step")
    assert not refused.ok and "changed since you looked" in refused.reason
