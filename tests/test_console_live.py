"""The live console against a real manager and a real virtual fleet on 127.0.0.1, under Xvfb.

Each test starts `fleetctl virtual-fleet` and `fleetctl manager` as processes
(`live.Proc`: own process groups, free ports, stopped by group), opens the console window in
this process with its real network thread, and pumps Tk like its main loop
would. What is checked is what an operator sees: canvas items where the
manager says the robots are, the robot list, the answer line, the event
list, the banner, and pixels of a screenshot. Waits for the fleet are
bounded loops; nothing is timed.
"""
from __future__ import annotations

import dataclasses
import gc
import re
import time
import tkinter as tk
from pathlib import Path
from typing import Callable, Iterator, List, Optional, Tuple

import numpy as np
import pytest
from PIL import Image

from console.live.feed import CONNECTED, LOST, LiveFeed
from console.live.link import ManagerLink
from console.live.model import LiveModel
from console.ui import capture
from console.ui.admin_panel import DISABLED, ENABLED
from console.ui.hover_tip import DELAY_MS
from console.ui.live_app import LiveApp
from console.ui.robot_layer import GREY
from console.ui.wait_layer import WAIT
from fleet_common.formats.instance import read_instance
from fleet_common.lab import lab_instance_path, lab_map_path
from fleet_common.planning import solve
from fleetctl.live_demo import pick_stall
from helpers import Forwarder
from live import Proc, fleet_definitions, start_fleet, start_manager

LAB = str(lab_instance_path())


class Lab:
    """Five robots on 127.0.0.1 as a virtual fleet (on the lab's starts) and managers for them."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.definitions, self.feedback, self.port = fleet_definitions(folder, 5)
        self.endpoint = "tcp://127.0.0.1:{}".format(self.port)
        self.procs: List[Proc] = []

    def fleet(self, time_scale: float = 4.0, stall: Optional[str] = None, *extra: str) -> Proc:
        proc = start_fleet(self.folder, self.definitions, self.feedback, "--time-scale", time_scale,
                           *(["--stall", stall] if stall else []), *extra)
        self.procs.append(proc)
        return proc

    def start_manager(self, *extra: str, plan: object = LAB) -> Proc:
        proc = start_manager(self.folder, plan, self.definitions, self.port, "--log", self.folder / "runs",
                             "--step-time", "0.6", *extra, name="manager-{}".format(len(self.procs)))
        self.procs.append(proc)
        return proc

    def stop(self) -> None:
        for proc in reversed(self.procs):
            proc.stop()


@pytest.fixture(name="lab")
def lab_fixture(tmp_path: Path) -> Iterator[Lab]:
    """The lab on virtual robots with a manager (test_console_demo uses it too)."""
    lab = Lab(tmp_path)
    try:
        yield lab
    finally:
        lab.stop()


class Console:
    """A live console window in this process: its link thread, feed, model and app."""

    def __init__(self, master: tk.Misc, endpoint: str, name: str, timeout: float = 3.5) -> None:
        self.feed = LiveFeed()
        self.model = LiveModel(endpoint)
        self.link = ManagerLink(endpoint, self.feed, name=name, timeout=timeout).start()
        self.app = LiveApp(master, self.feed, self.model, self.link.request, canvas_size=(560, 600))

    def close(self) -> None:
        self.link.stop()


@pytest.fixture
def consoles(display: str) -> Iterator[Callable[..., Console]]:
    root = tk.Tk()
    root.geometry("+0+0")
    opened: List[Console] = []

    def open_console(endpoint: str, name: str = "test console", timeout: float = 3.5) -> Console:
        master = root if not opened else tk.Toplevel(root)
        console = Console(master, endpoint, name, timeout)
        opened.append(console)
        root.update()
        return console

    try:
        yield open_console
    finally:
        for console in opened:
            console.close()
        if root.winfo_exists():
            root.destroy()
        gc.collect()  # Tk objects must die on this (Tk's) thread


def pump(console: Console, until: Callable[[], bool], seconds: float = 30.0) -> bool:
    """Run the window's loop until `until()` holds (True) or `seconds` pass (False)."""
    deadline = time.monotonic() + seconds
    root = console.app.root
    while time.monotonic() < deadline:
        root.update()
        if until():
            return True
        time.sleep(0.01)
    return False


def canvas_xy(app: LiveApp, cells: np.ndarray) -> np.ndarray:
    """Canvas centres of `cells` by the viewport's documented rule (rows from the top)."""
    v, h = app.map.view, app.scene.grid.height
    return np.column_stack([v.ox + (cells[:, 0] + 0.5) * v.cell, v.oy + (h - 1 - cells[:, 1] + 0.5) * v.cell])


def running(console: Console) -> bool:
    s = console.model.state
    return s is not None and s.run.state == "running"


def header_clock(app: LiveApp) -> Tuple[float, float]:
    """The plan clock the operator's header shows, "t = 8.50 / 19": the time and the end."""
    found = re.search(r"t = ([0-9.]+) / ([0-9.]+)", app.header.text())
    assert found, app.header.text()
    return float(found.group(1)), float(found.group(2))


def tree_row(console: Console, robot_id: int) -> Tuple[str, ...]:
    return tuple(console.app.admin.tree.item(str(robot_id), "values"))


# ---- the map follows the robots ---------------------------------------------------------

def test_every_robot_is_drawn_where_the_newest_state_says(lab: Lab, consoles) -> None:
    lab.fleet(time_scale=3.0)
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    assert pump(console, lambda: running(console) and model.scene is not None), model.connection.text
    checked, seen = 0, []
    deadline = time.monotonic() + 30
    while checked < 25 and time.monotonic() < deadline:
        app.root.update()
        app.refresh()  # what one frame does: drain the feed, draw the newest state
        assert len(console.feed) == 0 or console.feed.drain(0) == []
        if app.state is None or (seen and app.state.version == seen[-1][0]):
            time.sleep(0.01)
            continue
        state = model.state
        assert app.state.version == state.seq  # the state drawn is the newest that arrived
        poses = np.array([[r.x, r.y] for r in sorted(state.robots, key=lambda r: model.agent_of[r.id])])
        np.testing.assert_allclose(app.agents.centres, canvas_xy(app, poses), atol=0.06)
        seen.append((state.seq, poses))
        checked += 1
    assert checked == 25
    assert not np.allclose(seen[0][1], seen[-1][1])  # they moved meanwhile


# ---- the admin panel acts through the manager ----------------------------------------------

def test_clicking_a_robots_enabled_box_disables_it_in_the_manager(lab: Lab, consoles) -> None:
    lab.fleet()
    lab.start_manager()
    console = consoles(lab.endpoint)
    tree = console.app.admin.tree
    up = lambda: all(r.link == "up" for r in console.model.state.robots)  # noqa: E731
    assert pump(console, lambda: tree.exists("3") and tree_row(console, 3)[2] == ENABLED and up())
    x, y, w, h = tree.bbox("3", "#3")
    tree.event_generate("<ButtonPress-1>", x=x + w // 2, y=y + h // 2)
    tree.event_generate("<ButtonRelease-1>", x=x + w // 2, y=y + h // 2)
    robot = console.model.robot
    assert pump(console, lambda: robot(3).out == "disabled" and tree_row(console, 3)[2] == DISABLED)
    assert "disabled" in tree_row(console, 3)[1]  # greyed, with the reason
    assert robot(2).out is None
    assert "disable robot=3: done" in console.app.admin.answer.cget("text")
    assert any("disable robot=3: done" in line for line in console.app.events.rows())
    assert console.app.selected_robot() == 3  # the click picked the robot too
    assert "disabled" in console.app.robot_panel.content()
    console.app.select(None)
    events = console.app.events.tree
    line = next(i for i in events.get_children() if "disable robot=3" in events.item(i, "values")[2])
    x, y, w, h = events.bbox(line)
    for _ in range(2):  # a double click, as the X server would send it
        events.event_generate("<ButtonPress-1>", x=x + w // 2, y=y + h // 2)
        events.event_generate("<ButtonRelease-1>", x=x + w // 2, y=y + h // 2)
    assert console.app.selected_robot() == 3  # the event list jumps to the robot it is about


@pytest.mark.parametrize("posted", ["menu", "drop-down"])
def test_the_robot_table_keeps_updating_while_a_menu_is_posted(lab: Lab, consoles, caplog, posted: str) -> None:
    """An operator reaching for Halt with a menu or the strategy drop-down open reads current rows:
    the table goes on changing at its pace, and no frame fails."""
    lab.fleet(2.0)
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app = console.app
    assert pump(console, lambda: running(console) and tree_row(console, 1) != (), 60)
    root = app.root
    if posted == "menu":  # Run in the menu bar, posted as a click on it does, the focus in it
        app.menubar.entryconfigure("Run", underline=0)
        root.tk.call("tk::TraverseToMenu", str(root), "r")
        root.update()
        clones = [w for w in root.tk.call("winfo", "children", ".") if "#" in str(w)]
        root.tk.call("focus", str(clones[0]))  # where a desktop's window manager puts it
    else:  # the strategy drop-down, open
        root.tk.call("ttk::combobox::Post", str(app.admin.strategy_box))
    root.update()
    focus = str(root.tk.call("focus"))
    assert "#" in focus or "popdown" in focus, focus  # a widget tkinter does not know has the focus
    # the pose's age changes at every refresh of the panels (four a second): six different rows
    # come within 1.5 s on a quiet machine; waited for up to 20 s, so a loaded one does not fail
    rows, seen = [], time.monotonic()
    while len(rows) < 6 and time.monotonic() - seen < 20.0:
        root.update()
        row = tree_row(console, 1)
        if not rows or row != rows[-1]:
            rows.append(row)
        time.sleep(0.01)
    assert len(rows) >= 6, rows
    assert not [r for r in caplog.records if "frame failed" in r.getMessage()]
    root.tk.call("tk::MenuUnpost", "") if posted == "menu" else root.tk.call(
        "ttk::combobox::Unpost", str(app.admin.strategy_box))


# ---- a stalled robot and the robot that waits for it -----------------------------------------

def test_a_stalled_robot_makes_its_dependent_show_the_red_frame_and_arrow(lab: Lab, consoles,
                                                                          tmp_path: Path) -> None:
    inst = read_instance(LAB, map_dirs=[lab_map_path().parent])
    plan = solve("cbs", inst.grid, inst.starts, inst.goals, seed=0).plan  # what the manager plans
    choice = pick_stall(plan)
    staller, waiter = choice.agent + 1, choice.waiter + 1  # lab robots 1..5 are agents 0..4
    lab.fleet(time_scale=4.0, stall="{}:{}:200".format(staller, choice.move))
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model

    def shown() -> bool:
        r = model.robot(waiter)
        return (r is not None and r.waiting is not None and staller in r.waiting.on
                and any(w.agent == choice.waiter for w in (app.agents.picture.waits if app.agents.picture else [])))

    assert pump(console, shown, 60), [model.robot(waiter)]
    pump(console, lambda: False, 0.3)  # a few more frames: everything drawn
    png = tmp_path / "wait.png"
    capture.grab(app.canvas, png)
    with Image.open(png) as image:
        rgb = np.asarray(image.convert("RGB")).astype(int)
    red = np.array([int(WAIT[k:k + 2], 16) for k in (1, 3, 5)])

    def is_red(x: float, y: float) -> bool:
        near = rgb[int(y) - 1:int(y) + 2, int(x) - 1:int(x) + 2].reshape(-1, 3)
        return bool((np.abs(near - red).sum(axis=1) < 60).any())

    v = app.map.view
    cx, cy = canvas_xy(app, np.array([choice.cell], dtype=float))[0]
    half = v.cell / 2 - max(2, round(v.cell * 0.08)) / 2
    # the frame's edge away from both robots: the side the staller is not on
    pw = model.robot(waiter)
    ps = model.robot(staller)
    side = -1.0 if ps.x > choice.cell[0] else 1.0
    edge = [is_red(cx + side * half, cy + f * half) for f in (-0.6, -0.3, 0.3, 0.6)]
    assert all(edge), edge
    a, b = canvas_xy(app, np.array([[pw.x, pw.y], [ps.x, ps.y]]))
    d = np.hypot(*(b - a))
    u = (b - a) / d
    r = app.agents.radius
    # along the arrow, from inside the waiting robot's disc to the staller's rim
    along = [is_red(*(a + u * (0.45 * r + f * (d - 1.45 * r)))) for f in (0.1, 0.4, 0.7)]
    assert all(along), along
    # and far from any frame or arrow, no red: a plain free cell
    assert not is_red(*canvas_xy(app, np.array([[0.0, 2.0]]))[0])
    chain = app.robot_panel
    app.jump_to_robot(waiter)
    app.update_panels()
    assert "robot {} waits for robot {}".format(waiter, staller) in chain.content()


# ---- two consoles, and an outdated request -------------------------------------------------

def test_a_request_on_an_outdated_picture_is_refused_and_the_refusal_shown(lab: Lab, consoles) -> None:
    lab.fleet()
    lab.start_manager()
    first = consoles(lab.endpoint, "first")
    slow_net = Forwarder(lab.port)
    try:
        second = consoles("tcp://127.0.0.1:{}".format(slow_net.port), "second", timeout=60.0)
        both = lambda: all(c.model.robot(4) is not None for c in (first, second))  # noqa: E731
        assert pump(first, both)
        slow_net.held.set()  # the second console's picture freezes here
        first.app.ask("disable", robot=4)
        assert pump(first, lambda: first.model.robot(4).out == "disabled")
        assert second.model.robot(4).out is None  # it has not heard
        second.app.ask("disable", robot=4)  # what it sees: robot 4 enabled
        assert not pump(second, lambda: second.model.last_reply is not None, 0.5)  # the answer is held too
        slow_net.held.clear()
        assert pump(second, lambda: second.model.last_reply is not None)
    finally:
        slow_net.close()
    reply = second.model.last_reply
    assert not reply.ok and "state changed since you looked" in reply.reason and "robot 4 disabled" in reply.reason
    shown = second.app.admin.answer
    assert "REFUSED" in shown.cget("text") and str(shown.cget("foreground")) == "#c8101a"
    assert any("disable robot=4: REFUSED" in line for line in second.app.events.rows())
    assert pump(second, lambda: second.model.robot(4).out == "disabled")  # and then it sees why


# ---- the manager goes away and comes back --------------------------------------------------

def test_a_lost_manager_is_shown_and_the_console_reconnects(lab: Lab, consoles) -> None:
    lab.fleet()
    first = lab.start_manager()
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    assert pump(console, lambda: model.connected and model.state is not None)
    first.stop()  # the manager process goes (SIGINT: it tells nobody, it just closes)
    assert pump(console, lambda: model.connection.status == LOST, 20)
    assert pump(console, lambda: "MANAGER LOST" in app.admin.connection.cget("text"), 2)
    assert "manager lost" in app.banner.text
    assert app.canvas.itemcget(app.banner.label, "state") == "normal"
    assert all(label == "manager lost" for label in app.agents.picture.labels)
    lab.start_manager()
    assert pump(console, lambda: model.connection.status == CONNECTED and model.state is not None, 30)
    assert pump(console, lambda: app.banner.text == "" and not app.agents.picture.grey.any(), 5)
    assert any("reconnected to the manager" in line for line in app.events.rows())


# ---- replanning: the proposal on the map, then accepted ------------------------------------

def test_a_replan_proposal_is_drawn_and_accepting_it_switches_the_map_to_the_new_plan(lab: Lab, consoles,
                                                                                       tmp_path: Path) -> None:
    lab.fleet(time_scale=4.0)
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    assert pump(console, lambda: running(console) and model.state.run.plan_time > 2)
    app.admin.buttons["replan"].invoke()
    assert pump(console, lambda: model.proposal is not None, 60), [line.text for line in model.lines]
    assert pump(console, lambda: bool(app.proposal.items), 2)
    assert len(app.canvas.find_withtag("proposal")) == len(app.proposal.items) > 0
    assert "REPLAN PROPOSAL {}".format(model.proposal.id) in app.header.text()
    assert pump(console, lambda: "replan {} proposed".format(model.proposal.id) in app.header.text(), 5)
    assert app.header.text().count("accept or reject") == 1, app.header.text()  # said once, first
    capture.grab(app.root, tmp_path / "replan-proposal.png")
    assert pump(console, lambda: "disabled" not in app.admin.buttons["accept"].state(), 2)
    old_plan = model.setup.plan.id
    app.admin.buttons["accept"].invoke()
    assert pump(console, lambda: model.setup.plan.id != old_plan and model.proposal is None, 30), "\n".join(line.text for line in model.lines)
    assert pump(console, lambda: not app.canvas.find_withtag("proposal") and app.state is not None, 5)
    assert pump(console, lambda: "disabled" in app.admin.buttons["accept"].state(), 2)
    assert any("accept proposal=" in line and ": done" in line for line in app.events.rows())
    # the new map's robots are where the manager says, drawn on a freshly built canvas
    assert pump(console, lambda: app.agents.picture is not None and app.agents.picture.num_agents == 5, 5)


def press(button: tk.Widget) -> None:
    """A click on `button` as the pointer makes it: press and release over it."""
    button.event_generate("<ButtonPress-1>", x=5, y=5)
    button.event_generate("<ButtonRelease-1>", x=5, y=5)


def test_a_greyed_replan_pressed_asks_and_the_answer_line_says_why_not(lab: Lab, consoles) -> None:
    """Robot 2's bumper stops it halfway through its 2nd drive; enabled again while the run is
    paused, it stands between two cells and the manager will not replan (its State greys Replan).
    Pressing the greyed button asks all the same: the answer line says why; nothing else changes."""
    lab.fleet(4.0, None, "--bump", "2@2")
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    assert pump(console, lambda: model.robot(2) is not None and model.robot(2).out == "failed", 60)
    app.admin.buttons["pause"].invoke()
    assert pump(console, lambda: model.state.run.state == "paused", 10)
    pump(console, lambda: False, 0.5)  # the foot leaves the bumper (1 fleet second)
    app.ask("enable", robot=2)
    assert pump(console, lambda: model.robot(2).out is None, 10)
    replan = app.admin.buttons["replan"]
    assert pump(console, lambda: replan.instate(["disabled"]), 5)
    plan = model.setup.plan.id
    press(replan)
    assert pump(console, lambda: model.last_reply is not None and not model.last_reply.ok, 10)
    shown = app.admin.answer.cget("text")
    assert "replan: REFUSED: robot 2 stopped between two cells after a fault" in shown, shown
    assert model.proposal is None and model.setup.plan.id == plan and model.state.run.state == "paused"
    # an enabled button pressed asks once, by its own binding: Start goes on as ever
    start = app.admin.buttons["start"]
    assert start.instate(["!disabled"])
    sent: List[str] = []
    ask = app.admin.on_action
    app.admin.on_action = lambda action, **args: (sent.append(action), ask(action, **args))
    press(start)
    assert sent == ["start"], sent
    assert pump(console, lambda: running(console), 10)


# ---- rerouting: the mode picked in the console, a reroute proposal on the map ---------------

def test_a_reroute_proposal_is_drawn_with_who_goes_round_whom_and_the_mode_is_picked_here(
        lab: Lab, consoles, tmp_path: Path) -> None:
    lab.fleet(4.0, "4:3:40")  # robot 4 halts 10 s halfway through its 3rd drive; robot 1 waits for it
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    assert pump(console, lambda: running(console))
    app.admin.reroute.set("propose")  # the operator picks the mode where the strategy is picked
    app.admin.reroute_box.event_generate("<<ComboboxSelected>>")
    assert pump(console, lambda: model.state.run.reroute == "propose", 5)
    assert pump(console, lambda: model.proposal is not None, 60), [line.text for line in model.lines]
    assert model.proposal.kind == "reroute" and model.state.run.state == "running"  # the run goes on
    assert pump(console, lambda: bool(app.canvas.find_withtag("proposal")), 2)
    header = app.header.text()
    # the header's status says what is proposed, in the manager's words, and the mode
    assert "REROUTE PROPOSAL {} (dashed; accept or reject): {}".format(
        model.proposal.id, model.proposal.message) in header, header
    assert model.proposal.message.startswith("robot 4, late ") and header.endswith("reroute propose")
    assert pump(console, lambda: "disabled" not in app.admin.buttons["accept"].state(), 2)
    pump(console, lambda: False, 0.3)  # a few more frames: everything drawn
    capture.grab(app.root, tmp_path / "reroute-proposal.png")
    message, old_plan = model.proposal.message, model.setup.plan.id
    shown = header_clock(app)[0]
    app.admin.buttons["accept"].invoke()  # robot 4 still stands: it fits
    assert pump(console, lambda: model.setup.plan.id != old_plan and model.proposal is None, 10), \
        "\n".join(line.text for line in model.lines)
    # the header's plan clock is the run's: on from where it was, up to the new plan's end in the run
    assert pump(console, lambda: model.state.run.plan_start > 0 and app.state.version == model.state.seq, 5)
    run = model.state.run
    t, end = header_clock(app)
    assert t >= shown and t == pytest.approx(run.plan_start + run.plan_time, abs=0.01)
    assert end == pytest.approx(run.plan_start + model.setup.plan.positions.shape[0] - 1, abs=0.05)
    assert pump(console, lambda: not app.canvas.find_withtag("proposal"), 5)
    rows = app.events.rows()
    assert any(row.endswith(message) for row in rows)  # the manager's line, by robot id
    assert any(row.endswith(message.split(";")[0]) for row in rows)  # the ticker's, for visitors
    assert not any("replan proposal" in row for row in rows)
    app.admin.reroute.set("auto")
    app.admin.reroute_box.event_generate("<<ComboboxSelected>>")
    assert pump(console, lambda: model.state.run.reroute == "auto", 5)
    assert pump(console, lambda: any(row.endswith("rerouting now auto") for row in app.events.rows()), 5)
    app.admin.scope.set("all")  # and whom a reroute may give new paths: every robot
    app.admin.scope_box.event_generate("<<ComboboxSelected>>")
    assert pump(console, lambda: model.state.run.reroute_scope == "all", 5)
    assert pump(console, lambda: app.header.text().endswith("reroute auto, every robot"), 2), app.header.text()
    assert pump(console, lambda: any(row.endswith("rerouting now auto (every robot)")
                                     for row in app.events.rows()), 5)
    capture.grab(app.root, tmp_path / "reroute-scope.png")
    app.admin.trim.set(True)  # and reroutes' plans trimmed of moves that bring nobody in sooner
    app.admin._trim()  # as the check box's command, when clicked
    assert pump(console, lambda: model.state.run.trim is True, 5)
    assert pump(console, lambda: app.header.text().endswith("reroute auto, every robot, trimmed"), 2), \
        app.header.text()
    assert pump(console, lambda: any(row.endswith("plans now trimmed: fewer moves, nobody later")
                                     for row in app.events.rows()), 5)
    assert any(row.endswith("test console: reroute trim on") for row in app.events.rows())
    assert pump(console, lambda: app.admin.trim.get() is True, 2)  # the box as the State has it
    capture.grab(app.root, tmp_path / "reroute-trim.png")


# ---- robots that cannot be trusted stay on the map, greyed, with why ------------------------

@pytest.mark.parametrize("curve", [False, True])
def test_a_console_nobody_answers_says_the_port_or_the_keys_are_wrong(curve: bool) -> None:
    """A wrong port and a CurveZMQ manager that drops a console without its keys look the same
    from the console: silence. After a few seconds it says so, naming both causes, and keeps trying."""
    import zmq

    from fleet_common.transport.curve_keys import ConsoleKeys
    from helpers import free_port

    keys = None
    if curve:
        public, secret = zmq.curve_keypair()
        keys = ConsoleKeys(public, secret, zmq.curve_keypair()[0])
    feed = LiveFeed()
    endpoint = "tcp://127.0.0.1:{}".format(free_port())
    link = ManagerLink(endpoint, feed, keys=keys, no_answer=1.0, hello_every=0.3).start()
    try:
        said: List[str] = []
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not any("no answer" in t for t in said):
            said += [item.text for item, _ in feed.drain() if hasattr(item, "status")]
            time.sleep(0.05)
    finally:
        link.stop()
    line = next(t for t in said if "no answer" in t)
    assert line.startswith("no answer from a manager at {} for 1 s: is it running on that port?".format(endpoint))
    assert ("console.key_secret" if curve else "--no-curve") in line and line.endswith("still trying")


def test_a_faulty_robot_and_a_lost_fleet_are_greyed_with_the_reason_not_dropped(lab: Lab, consoles) -> None:
    fleet = lab.fleet(4.0, None, "--bump", "3@2")  # robot 3's bumper is hit in its 2nd drive
    lab.start_manager("--start")
    console = consoles(lab.endpoint)
    app, model = console.app, console.model
    agent = 2  # robot 3

    def label(i: int) -> str:
        item = app.agents.label_items.get(i)
        return app.canvas.itemcget(item, "text") if item is not None else ""

    assert pump(console, lambda: model.robot(3) is not None and "bumper" in model.robot(3).faults, 60)
    assert pump(console, lambda: label(agent) == "fault: bumper", 2)
    disc = app.agents.disc_items[agent]
    assert app.canvas.itemcget(disc, "fill") == GREY and app.canvas.itemcget(disc, "state") != "hidden"
    assert pump(console, lambda: tree_row(console, 3)[1] == "fault: bumper", 2)
    assert "fault: bumper" in app.agents.picture.labels[agent]
    fleet.kill()  # every robot gone at once, as at a power cut
    gone = lambda: all(r.link != "up" for r in model.state.robots)  # noqa: E731
    assert pump(console, gone, 30)
    assert pump(console, lambda: all(label(i).startswith("link ") for i in range(5)), 3)
    assert all(app.canvas.itemcget(d, "fill") == GREY for d in app.agents.disc_items)
    assert len(app.admin.tree.get_children()) == 5  # all still listed, greyed
    listed = lambda: all(tree_row(console, rid)[1].startswith("link ") for rid in range(1, 6))  # noqa: E731
    assert pump(console, listed, 2), [tree_row(console, rid) for rid in range(1, 6)]


def test_a_long_robot_list_writes_the_rows_in_view_and_the_others_as_they_scroll_in(display: str) -> None:
    from console.live.describe import RobotRow
    from console.ui.admin_panel import AdminPanel

    root = tk.Tk()
    try:
        panel = AdminPanel(root, lambda *a, **k: None, lambda rid: None)
        panel.pack(fill=tk.BOTH, expand=True)
        ids = list(range(1, 301))
        panel.set_fleet(ids, ["#ff0000"] * 300, ("adg",))
        root.update()
        made = []

        def row_of(i: int) -> RobotRow:
            made.append(i)
            return RobotRow(i, "up", "robot 0.1 s", True, "drive #{}".format(i), "", None, False)

        panel.show_rows(row_of)
        assert 8 <= len(made) <= 20  # the rows in view (and a few beyond), not 300
        values = lambda rid: panel.tree.item(str(rid), "values")  # noqa: E731
        assert values(1)[3] == "drive #1" and values(290) == ""
        panel.tree.yview_moveto(1.0)
        root.update()
        assert values(300)[3] == "drive #300" and values(295)[3] == "drive #295"
        assert values(150) == ""  # never in view: never written
    finally:
        root.destroy()
        gc.collect()



def test_the_run_menu_and_the_run_buttons_ask_the_same_actions(display: str) -> None:
    """One table of run controls: each button and each Run menu entry sends its action, one the
    manager knows (accept and reject only as buttons: they name the proposal shown), and both
    are greyed when the manager would refuse it (without a manager: all of them)."""
    from console.live.feed import LinkStatus
    from console.ui.admin_panel import RUN_CONTROLS
    from fleet_common.control import ACTIONS, RUN_ACTIONS, RunInfo, State

    asked: List[str] = []
    root = tk.Tk()
    try:
        feed, model = LiveFeed(), LiveModel("tcp://127.0.0.1:1")
        app = LiveApp(root, feed, model, lambda action, **args: asked.append(action))
        root.after_cancel(app._after)
        run = app.menubar.nametowidget(app.menubar.entrycget("Run", "menu"))
        labels = [run.entrycget(i, "label") for i in range(run.index("end") + 1)]
        assert labels == [c.menu for c in RUN_CONTROLS if c.menu is not None]

        def press_all() -> Tuple[List[str], List[str]]:
            for i in range(len(labels)):
                run.invoke(i)
            menu_asked, asked[:] = list(asked), []
            for c in RUN_CONTROLS:
                app.admin.buttons[c.action].invoke()
            buttons, asked[:] = list(asked), []
            return menu_asked, buttons

        assert press_all() == ([], [])  # no manager yet: nothing to ask
        feed.offer(LinkStatus(CONNECTED, "connected"), 0.0)
        everything = RunInfo("paused", "", "adg", 1, 3.0, 1.0, 1, 0, 5, None, 0, 7, allowed=RUN_ACTIONS)
        feed.offer(State(1, 3, everything, ()), 0.0)
        app.refresh()
        menu_asked, buttons = press_all()
        assert menu_asked == [c.action for c in RUN_CONTROLS if c.menu is not None]
        assert buttons == [c.action for c in RUN_CONTROLS]
        assert {c.action for c in RUN_CONTROLS} <= set(ACTIONS)
        only_start = dataclasses.replace(everything, state="waiting", proposal=None, allowed=("start",))
        feed.offer(State(2, 3, only_start, ()), 0.0)
        app.refresh()
        assert press_all() == (["start"], ["start"])
        assert app.admin.buttons["reset"].instate(["disabled"])
        # a refusal stays on the answer line while the run stays where it was refused, no longer
        from console.live.feed import Reply
        feed.offer(Reply("start", {}, False, "not on their start cells"), 0.0)
        app.refresh()
        app.update_panels({"reply"})
        assert "REFUSED" in app.admin.answer.cget("text")
        feed.offer(State(3, 4, dataclasses.replace(only_start, state="running", allowed=()), ()), 0.0)
        app.refresh()
        app.update_panels({"state"})
        assert app.admin.answer.cget("text") == ""
        assert run.entrycget(labels.index(next(c.menu for c in RUN_CONTROLS if c.action == "reset")),
                             "state") == "disabled"
    finally:
        root.destroy()
        gc.collect()

def test_a_greyed_start_says_why_on_hover_and_its_run_menu_entry_too(display: str) -> None:
    """The State says why Start would be refused: the pointer resting on the greyed button shows
    that sentence in a note below it, the Run menu's greyed entry begins it after a dash; once
    the manager allows Start, the note goes and the entry is plain "Start" again."""
    from types import SimpleNamespace

    from console.live.feed import LinkStatus
    from console.ui.live_actions import MENU_WHY_CHARS
    from fleet_common.control import RunInfo, State

    why = ("not on their start cells (the plan file's coordinates): robot 3 is at (5, 10), its start is "
           "(5, 1); Go to starts drives them there, or continue their last run (fleetctl manager --resume)")
    root = tk.Tk()
    try:
        feed, model = LiveFeed(), LiveModel("tcp://127.0.0.1:1")
        app = LiveApp(root, feed, model, lambda action, **args: None)
        root.after_cancel(app._after)
        window = SimpleNamespace(app=app)
        feed.offer(LinkStatus(CONNECTED, "connected"), 0.0)
        waiting = RunInfo("waiting", "", "adg", 1, 0.0, 0.0, 1, 0, 5, None, 0, None, allowed=("to_starts",),
                          why_not={"start": why, "halt": "nothing is moving (the run is waiting)"})
        feed.offer(State(1, 3, waiting, ()), 0.0)
        app.refresh()
        start, tip = app.admin.buttons["start"], app.admin.tips["start"]
        assert start.instate(["disabled"]) and not tip.shown
        start.event_generate("<Enter>", x=5, y=5)
        assert pump(window, lambda: tip.window is not None and tip.window.winfo_viewable(), 5)
        assert tip.shown == why
        assert tip.window.winfo_rooty() >= start.winfo_rooty() + start.winfo_height()  # below, not over it
        menu = app.run_menu
        label = menu.entrycget(0, "label")
        assert label.startswith("Start \u2014 not on their start cells (the plan file's coordinates): robot 3 is")
        assert label.endswith("\u2026") and len(label) <= len("Start \u2014 ") + MENU_WHY_CHARS + 1
        assert menu.entrycget(0, "state") == "disabled"
        assert menu.entrycget(3, "label") == "Stop \u2014 the manager would refuse it now (press it to ask why)"
        # the manager allows Start: the note goes at once, the entry is plain again
        feed.offer(State(2, 4, dataclasses.replace(waiting, allowed=("start", "step"), why_not={}), ()), 0.0)
        app.refresh()
        assert start.instate(["!disabled"]) and tip.window is None
        assert menu.entrycget(0, "label") == "Start" and menu.entrycget(0, "state") == "normal"
        start.event_generate("<Leave>")
        start.event_generate("<Enter>", x=5, y=5)  # an enabled button has nothing to explain
        pump(window, lambda: False, 2 * DELAY_MS / 1000)
        assert tip.window is None
    finally:
        root.destroy()
        gc.collect()


def test_the_presentation_view_shows_the_map_alone_and_f11_brings_the_operators_window_back(display: str) -> None:
    from console.live.feed import LinkStatus
    from fleet_common.control import Notice, PlanData, Proposal, RunInfo, State

    root = tk.Tk()
    try:
        feed, model = LiveFeed(), LiveModel("tcp://127.0.0.1:1")
        app = LiveApp(root, feed, model, lambda action, **args: None, present=True)
        root.update()
        assert not app.admin.winfo_ismapped() and not app.right.winfo_ismapped()
        assert app.canvas.winfo_width() == root.winfo_screenwidth()  # the whole screen
        assert app.canvas.itemcget(app.header.line1, "state") == "hidden"
        feed.offer(LinkStatus(CONNECTED, "connected"), 0.0)
        feed.offer(State(1, 1, RunInfo("waiting", "", "adg", 1, 0.0, 0.0, 1, 0, 5, None, 0, None), ()), 0.0)
        feed.offer(State(2, 1, RunInfo("running", "", "adg", 1, 1.0, 0.5, 1, 0, 5, None, 0, None), ()), 0.1)
        feed.offer(Notice(1, 1.0, "plan", None, "replanned 4 robots: plan 2 (planned by pp)"), 0.2)
        for _ in range(3):
            app.refresh()
            root.update()
        text = app.bands.text()
        assert "running" in text and "0 of 5 at their goals" in text and "dashed" not in text
        assert text.splitlines()[-1].endswith("replanned 4 robots")
        assert text.splitlines()[-2].endswith("the run starts: 5 robots")
        # a reroute proposed: its paths are dashed on the map, and the title band says what they are
        plan = np.zeros((2, 5, 2), dtype=np.int32)
        feed.offer(Proposal(7, PlanData(1007, (1, 2, 3, 4, 5), plan), "robot 4 late", 2, 1, kind="reroute"), 0.3)
        feed.offer(State(3, 2, RunInfo("running", "", "adg", 1, 2.0, 1.0, 1, 0, 5, None, 0, 7), ()), 0.3)
        for _ in range(3):
            app.refresh()
            root.update()
        assert "dashed: a new way round, for the operator to accept" in app.bands.text()
        feed.offer(State(4, 3, RunInfo("running", "", "adg", 1, 3.0, 1.5, 1, 0, 5, None, 0, None), ()), 0.4)
        for _ in range(3):
            app.refresh()
            root.update()
        assert "dashed" not in app.bands.text()  # answered or dropped: the words go with the dashes
        view = app.map.view
        assert view.top > 42 and view.bottom > 0 and view.right > 0  # title, ticker and legend beside the map
        app.canvas.focus_force()
        root.update()
        app.canvas.event_generate("<KeyPress-F11>")  # the key, as the X server would send it
        root.update()
        assert app.admin.winfo_ismapped() and app.right.winfo_ismapped() and not app.presentation.on
        assert app.canvas.itemcget(app.header.line1, "state") == "normal"
        assert (app.map.view.top, app.map.view.bottom, app.map.view.right) == (42, 0, 0)
    finally:
        root.destroy()
        gc.collect()


def _pictures(root: tk.Tk) -> set:
    return {name for name in root.image_names() if name.startswith("pyimage")}


def test_a_replaced_map_gives_its_picture_back_to_tk_at_once(display: str) -> None:
    """A new scene replaces the map; its picture goes with it, not when a collector finds it."""
    from console.ui.map_view import MapView
    from console.ui.tk_gc import TkThreadCollector

    root = tk.Tk()
    try:
        TkThreadCollector(root)  # no collection but the window's own
        view = MapView(root, np.ones((6, 8), dtype=bool), 200, 150)
        view.pack()
        root.update()
        view.redraw_map()
        pictures = _pictures(root)
        assert pictures
        view.destroy()
        del view
        assert not pictures & _pictures(root)
    finally:
        root.destroy()


def test_tk_garbage_is_freed_on_tks_thread_whichever_thread_allocates(display: str) -> None:
    """The network thread and job threads allocate all the time; Python's collector would free
    Tk garbage on them, which Tk refuses (and the picture would stay in Tcl for good)."""
    import sys
    import threading

    from console.ui.tk_gc import TkThreadCollector

    refused: List[object] = []
    saved_hook = sys.unraisablehook
    sys.unraisablehook = refused.append
    root = tk.Tk()
    try:
        TkThreadCollector(root)
        for _ in range(5):  # widgets holding a picture and a variable, in a cycle, destroyed
            holder = tk.Frame(root)
            holder.picture = tk.PhotoImage(master=root, width=4, height=4)  # type: ignore[attr-defined]
            holder.variable = tk.StringVar(master=root)  # type: ignore[attr-defined]
            holder.itself = holder  # type: ignore[attr-defined]
            holder.destroy()
        del holder
        pictures = _pictures(root)
        assert len(pictures) == 5

        def allocate() -> None:  # far past the collector's thresholds, in cycles
            for _ in range(50000):
                cycle: List[object] = []
                cycle.append(cycle)

        worker = threading.Thread(target=allocate)
        worker.start()
        worker.join()
        assert refused == []
        deadline = time.monotonic() + 5.0
        while pictures & _pictures(root) and time.monotonic() < deadline:
            root.update()
            time.sleep(0.02)
        assert not pictures & _pictures(root)  # freed, on Tk's thread
        assert refused == []
    finally:
        sys.unraisablehook = saved_hook
        root.destroy()
