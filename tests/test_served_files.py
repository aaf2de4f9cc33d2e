"""A console cannot make the manager open what it was not told to serve.

`ServedFolders` on its own (FIFOs, devices, symlinks out, absolute paths,
`..`, oversized files; any name at all), then the manager's `load` request in
memory: refused at once, the run unaffected, and no reply carrying a byte of
a file the console could not already read. A live manager with robots
connected answers a `load` of a FIFO at once and no robot link drops.
"""
from __future__ import annotations

import os
import shutil
import threading
from pathlib import Path
from typing import Callable

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.lab import lab_instance_path
from fleet_common.limits import MAX_PLAN_TEXT
from fleet_common.plan_loading import load_plan
from fleet_common.served_files import NotServed, ServedFolders
from fleet_manager.settings import ManagerSettings
from live import ScriptedConsole, fleet_definitions, start_fleet, start_manager
from memory_fleet import MemoryFleet, lab_fleet

# a secret that a map reader would quote if it were made to read it (a row of the wrong length)
SECRET = "height 1\nwidth 3\nmap\nroot:SECRET-MARKER-7f3a:20228:0:99999:7:::"


@pytest.fixture
def place(tmp_path: Path):
    """A served folder holding the lab instance, its map, a FIFO and symlinks, beside a secret."""
    served = tmp_path / "served"
    served.mkdir()
    lab = lab_instance_path()
    shutil.copy(lab, served / "lab.txt")
    shutil.copy(lab.parent / "lab.map", served / "lab.map")
    secret = tmp_path / "shadow"
    secret.write_text(SECRET + "\n")
    os.mkfifo(served / "fifo")
    os.symlink(secret, served / "link-out")
    os.symlink(served / "lab.txt", served / "link-in")
    os.symlink(served / "fifo", served / "link-fifo")
    (served / "big.txt").write_bytes(b"x" * (MAX_PLAN_TEXT + 1))
    return served, secret


def at_once(call: Callable[[], object]) -> object:
    """`call()` in a thread that must end within 5 s (a blocking open would not)."""
    out = {}

    def run() -> None:
        try:
            out["value"] = call()
        except Exception as err:  # the test looks at it
            out["error"] = err

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(5.0)
    assert not thread.is_alive(), "blocked: it did not answer within 5 s"
    if "error" in out:
        raise out["error"]
    return out.get("value")


@pytest.mark.parametrize("name,why", [
    ("fifo", "not a regular file (a FIFO)"),
    ("link-fifo", "not a regular file (a FIFO)"),
    ("link-out", "leads out of the served folder"),
    ("/etc/shadow", "an absolute path"),
    ("../shadow", "'..' leads out"),
    ("sub/../../shadow", "'..' leads out"),
    ("big.txt", "a served plan may have at most"),
    ("missing.txt", "no such plan"),
    ("lab.txt\x00.map", "control characters"),
])
def test_a_name_outside_what_is_served_is_refused_at_once_without_content(place, name, why) -> None:
    served, _ = place
    folders = ServedFolders([served], MAX_PLAN_TEXT, "plan")
    with pytest.raises(NotServed) as refused:
        at_once(lambda: folders.read(name))
    assert why in str(refused.value)
    assert "SECRET-MARKER" not in str(refused.value)


def test_devices_are_not_files_even_in_a_served_folder() -> None:
    folders = ServedFolders([Path("/dev")], 1000, "map")
    for name in ("zero", "null", "urandom"):
        with pytest.raises(NotServed, match="not a regular file \\(a device\\)"):
            at_once(lambda: folders.read(name))


def test_served_files_and_links_inside_are_read(place) -> None:
    served, _ = place
    folders = ServedFolders([served], MAX_PLAN_TEXT, "plan")
    real, text = folders.read("link-in")
    assert real == (served / "lab.txt").resolve() and text.startswith("map_file=lab.map")
    assert folders.find("/somewhere/else/lab.map")[0] == (served / "lab.map").resolve()  # by its name
    assert folders.find("../shadow") is None and folders.find("nothing.map") is None


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(min_size=0, max_size=60) | st.sampled_from(["..", "./..", "link-out/x", "fifo/", "//etc//shadow"]))
def test_any_name_is_read_inside_or_refused_and_never_shows_the_secret(place, name) -> None:
    served, _ = place
    folders = ServedFolders([served], MAX_PLAN_TEXT, "plan")
    try:
        real, _ = at_once(lambda: folders.read(name))
    except NotServed as err:
        assert "SECRET-MARKER" not in str(err)
    else:
        assert served.resolve() in real.parents and real.is_file() and not real.name.startswith("link")


# ---- the manager's load request, in memory ---------------------------------------------------

def fleet(plan_dirs) -> MemoryFleet:
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    return MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=0.5, plan_dirs=list(plan_dirs)))


def test_loads_a_console_may_not_make_are_refused_and_the_run_goes_on(place, tmp_path: Path) -> None:
    served, secret = place
    f = fleet([served])
    ops = f.console()
    f.link_up()
    lab_text = (served / "lab.txt").read_text()
    asks = [
        dict(path="fifo"), dict(path="link-out"), dict(path=str(secret)), dict(path="../shadow"),
        dict(path="big.txt"), dict(path="/dev/zero"),
        dict(text="x" * (MAX_PLAN_TEXT + 1), name="big"),
        dict(text=lab_text.replace("map_file=lab.map", "map_file={}".format(secret)), name="abs"),
        dict(text=lab_text.replace("map_file=lab.map", "map_file=../shadow"), name="up"),
        dict(text=lab_text.replace("map_file=lab.map", "map_file=link-out"), name="link"),
        dict(text=lab_text.replace("map_file=lab.map", "map_file=fifo"), name="fifo"),
        dict(text=lab_text, name="../../{}".format(secret.name)),  # a name is only a name
    ]
    before = (f.phase, f.core.run.loaded.name, f.folders)
    for args in asks:
        answer = at_once(lambda: f.ask(ops, "load", **args))
        if args.get("name", "").startswith("../"):
            assert answer.ok, answer.reason  # the text was the lab's, its map found served
            f.core.run.loaded = load_plan(lab_instance_path(), 5, "the lab fleet", [])
            continue
        assert not answer.ok, args
        assert "SECRET-MARKER" not in answer.reason and "root:" not in answer.reason, answer.reason
        if "text" in args and "map_file=" in args["text"] and "map_file=lab.map" not in args["text"]:  # never read
            assert any(why in answer.reason for why in (
                "is not in the folders this manager serves maps from", "leads out of the served folder",
                "not a regular file (a FIFO)")), answer.reason
    assert (f.phase, f.folders) == (before[0], before[2] + 1)
    everything = " ".join(a.reason for a in ops.answers()) + " ".join(str(x) for x in f.records)
    assert "SECRET-MARKER" not in everything
    # served by name: loaded (a new run, in a new folder), and it runs to the end
    assert f.ask(ops, "load", path="lab.txt").ok
    assert f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()


def test_an_instance_is_solved_off_the_loop_and_loaded_when_solved(place) -> None:
    """Solving takes up to the solver's time limit: the manager answers at once, goes on serving
    (States keep coming, the robots' links stay up), refuses to start the old plan meanwhile, and
    loads the plan when it is solved; an instance without a plan is said, and nothing changes."""
    served, _ = place
    f = fleet([served])
    ops = f.console()
    f.link_up()
    f.hold_loads = True
    answer = f.ask(ops, "load", path="lab.txt")
    assert answer.ok and "lab.txt is an instance: solving it" in answer.reason, answer.reason
    assert len(f.loads) == 1 and f.folders == 1  # not solved in the request, nothing loaded yet
    states = len(ops.states)
    f.advance(1.0)
    assert len(ops.states) > states  # the loop goes on
    start = f.ask(ops, "start")
    assert not start.ok and "lab.txt is being solved to be loaded" in start.reason
    again = f.ask(ops, "load", path="lab.txt")
    assert not again.ok and "being solved" in again.reason and len(f.loads) == 1
    f.finish_loads()
    f.advance(0.1)  # the manager's next turn carries out what the outcome asked for
    assert any(n.text.startswith("lab.txt loaded (") for n in ops.notices()), [n.text for n in ops.notices()]
    assert f.folders == 2 and f.phase == "waiting" and f.ask(ops, "start").ok
    assert f.run_until(lambda: f.phase == "done") and f.at_goals()
    # an instance its solver finds no plan for: the robots cannot reach their goals in 2 steps
    text = (served / "lab.txt").read_text().replace("max_timestep=100", "max_timestep=2")
    f.ask(ops, "reset")
    assert f.run_until(lambda: f.phase == "waiting")
    folders = f.folders
    assert f.ask(ops, "load", text=text, name="clash.txt").ok
    f.finish_loads()
    f.advance(0.1)
    told = [n.text for n in ops.notices() if "clash.txt" in n.text]
    assert told and told[-1].startswith("cannot load clash.txt: "), told
    assert f.folders == folders and f.ask(ops, "start").ok  # the plan there before runs


def test_without_served_folders_a_name_is_refused_and_content_is_asked_for(place) -> None:
    f = fleet([])
    ops = f.console()
    answer = f.ask(ops, "load", path="lab.txt")
    assert not answer.ok and "serves no folder of plans" in answer.reason and "content" in answer.reason
    answer = f.ask(ops, "load", text="x" * (MAX_PLAN_TEXT + 1), name="big")
    assert not answer.ok and "a plan sent as text may have at most" in answer.reason
    assert "xxxx" not in answer.reason


# ---- a live manager with its robots -----------------------------------------------------------

@pytest.mark.slow
def test_a_live_manager_answers_a_fifo_at_once_and_keeps_its_robots(place, tmp_path: Path) -> None:
    served, _ = place
    definitions, feedback, console_port = fleet_definitions(tmp_path, 5)
    fleet_proc = start_fleet(tmp_path, definitions, feedback, "--time-scale", "8")
    manager = start_manager(tmp_path, lab_instance_path(), definitions, console_port, "--plans", served,
                            "--until-done", "--log", tmp_path / "runs", "--time-limit", "120",
                            "--step-time", str(2.5 / 8))
    console = ScriptedConsole(console_port)
    try:
        console.wait_for(lambda c: c.state and all(r.link == "up" and r.age is not None for r in c.state.robots),
                         why="every robot connected")
        for name in ("fifo", "link-fifo", "link-out", "/etc/shadow", "../../etc/passwd"):
            answer = console.ask("load", path=name, timeout=5.0)
            assert not answer.ok and "SECRET-MARKER" not in answer.reason and "root:" not in answer.reason
        # an instance, solved in the manager's worker thread, then loaded: a new run
        answer = console.ask("load", path="lab.txt", timeout=5.0)
        assert answer.ok and "solving it" in answer.reason, answer.reason
        console.wait_for(lambda c: any(n.text.startswith("lab.txt loaded (") for n in c.session.notices),
                         why="the instance solved and loaded")
        console.wait_for(lambda c: c.state and "start" in c.state.run.allowed, why="Start allowed again")
        assert console.ask("start").ok
        assert manager.wait(120) == 0, manager.text()[-3000:]
    finally:
        console.close()
        manager.stop()
        fleet_proc.stop()
    out = manager.text()
    assert "link down" not in out and "silent for" not in out
    assert "SECRET-MARKER" not in out
