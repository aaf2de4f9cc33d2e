"""A whole demonstration from the live console alone, on a virtual fleet, under Xvfb.

Real processes on 127.0.0.1 (`fleetctl virtual-fleet`, `fleetctl manager`), the
console window in this process with its real network thread, driven by its
menus and buttons as an operator would (a menu entry's and a button's own
command, which is what a click runs; the file dialog answered with a path):
open an instance, solve it, send the robots to its starts, run it, reset,
run it again. What is checked is the manager's run folders: two complete
runs of the plan, the two ways to its starts, no collision anywhere.
"""
from __future__ import annotations

import tkinter as tk
from pathlib import Path
from typing import Callable, Dict, List


from console.ui import live_files
from fleet_common.formats.instance import read_instance
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.lab import lab_instance_path
from fleet_common.planning import solve
from fleet_common.runlog import read_run
from test_console_live import Console, Lab, lab_fixture, pump  # noqa: F401 (the fixture `lab`)

LAB = lab_instance_path()


def reversed_lab(folder: Path) -> Path:
    """A plan on the lab map from the lab instance's goals to its starts: where the robots stand
    when the demonstration begins (the last demonstration left them at the goals)."""
    inst = read_instance(str(LAB))
    result = solve("lacam", inst.grid, inst.goals, inst.starts)
    sol = make_solution(inst.grid, inst.map_file or "", result.plan, inst.goals, inst.starts, "lacam", True, 0)
    sol.orientation = inst.orientation
    path = folder / "back.txt"
    path.write_text(format_solution(sol))
    return path


def entry(menu: tk.Menu, label: str) -> int:
    for i in range(menu.index("end") + 1):
        if menu.type(i) != "separator" and menu.entrycget(i, "label").startswith(label):
            return i
    raise AssertionError("no menu entry {!r}".format(label))


def click(console: Console, action: str) -> None:
    """Press a run button once the manager allows it (it is greyed until then)."""
    button = console.app.admin.buttons[action]
    assert pump(console, lambda: not button.instate(["disabled"]), 60), \
        "{} stays greyed: {}".format(action, console.model.state and console.model.state.run)
    button.invoke()


def run_is(console: Console, state: str, purpose: str = "plan") -> Callable[[], bool]:
    def check() -> bool:
        s = console.model.state
        return s is not None and s.run.state == state and s.run.purpose == purpose
    return check


def folders(runs: Path) -> List[Dict]:
    out = []
    for folder in runs.iterdir():
        run = read_run(folder)
        first, end = run.last("run"), run.last("end")
        done = any(r.get("run") == "done" for r in run.of("state"))
        out.append({"started": first["started"], "purpose": first.get("purpose", "plan"), "done": done,
                    "end": end, "name": first["plan_name"]})
    return sorted(out, key=lambda f: f["started"])


def test_open_an_instance_solve_it_go_to_starts_run_reset_and_run_again(lab: Lab, display: str,
                                                                         monkeypatch) -> None:
    back = reversed_lab(lab.folder)
    lab.fleet(4.0, None, "--instance", str(back))  # the robots stand on the lab instance's goals
    manager = lab.start_manager(plan=back)
    root = tk.Tk()
    root.geometry("+0+0")
    console = Console(root, lab.endpoint, "demo console")
    try:
        app = console.app
        assert pump(console, lambda: console.model.setup is not None and console.model.connected, 30)
        # File -> Open an instance for the fleet (the dialog answers with the lab instance)
        monkeypatch.setattr(live_files.filedialog, "askopenfilename", lambda **kw: str(LAB))
        app.file_menu.invoke(entry(app.file_menu, "Open an instance"))
        assert pump(console, lambda: app.instance is not None, 30), [line.text for line in console.model.lines]
        assert any("fits the fleet" in line.text and "agent 0 -> robot 1" in line.text for line in console.model.lines)
        # File -> Solve the instance with -> cbs: planned here, sent to the manager as its text
        app.solve_menu.invoke(entry(app.solve_menu, "cbs"))
        assert pump(console, lambda: console.model.setup.plan.name.endswith("solved by cbs"), 60), \
            [line.text for line in console.model.lines]
        assert pump(console, run_is(console, "waiting"))
        assert app.admin.buttons["start"].instate(["disabled"]), "Start is greyed: robots are not on the starts"
        # Go to starts: a run of its own, then the plan waits for Start
        click(console, "to_starts")
        assert pump(console, run_is(console, "running", "to-starts"), 30)
        for turn in (1, 2):
            assert pump(console, lambda: run_is(console, "waiting")() and
                        "start" in (console.model.state.run.allowed or ()), 120)
            click(console, "start")
            assert pump(console, run_is(console, "done"), 120), console.model.state.run
            if turn == 1:
                click(console, "reset")  # the robots drive back to their starts, then the plan waits
        app.save_report(lab.folder / "report.html")  # File -> Save the run's report, the dialog answered
        report = (lab.folder / "report.html").read_text()
        assert "every robot is home" in report and (lab.folder / "report.png").stat().st_size > 0
        story = [line.text for line in console.model.lines if line.kind == "story"]
        assert "the robots drive to their starts" in story and "every robot is on its start: ready to run" in story
        assert sum(1 for s in story if s.startswith("every robot is home")) == 2
    finally:
        console.close()
        root.destroy()
    manager.stop()
    runs = folders(lab.folder / "runs")
    plans = [f for f in runs if f["purpose"] == "plan" and f["done"]]
    ways = [f for f in runs if f["purpose"] == "to-starts"]
    assert len(plans) == 2 and len(ways) == 2, runs
    for f in plans + ways:
        assert f["done"] and f["end"] is not None, f
        assert f["end"]["summary"]["collisions"] == 0 and f["end"]["arrived"] == 5, f
    assert all(f["name"].endswith("solved by cbs") for f in plans)
    assert [f["purpose"] for f in runs[-4:]] == ["to-starts", "plan", "to-starts", "plan"]
