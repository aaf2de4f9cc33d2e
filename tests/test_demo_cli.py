"""`fleetctl demo` and the live `fleetctl console` from the command line, as a visitor runs them:
headless (no DISPLAY), real processes on free loopback ports, every one of them gone at the end."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

from PIL import Image

from fleet_common.lab import lab_instance_path
from helpers import fleetctl, free_port_block


def headless() -> Dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != "DISPLAY"}


def pids(output: str) -> List[int]:
    line = re.search(r"^processes: virtual fleet pid (\d+), manager pid (\d+), console pid (\d+)", output, re.M)
    assert line, output
    return [int(p) for p in line.groups()]


def gone(pid: int) -> bool:
    """The process has ended (a zombie nobody reaped counts: it runs nothing)."""
    try:
        stat = Path("/proc/{}/stat".format(pid)).read_text()
    except OSError:
        return True
    return stat.rsplit(")", 1)[1].split()[0] == "Z"


def test_demo_runs_the_lab_scenario_headless_and_leaves_its_evidence(tmp_path: Path) -> None:
    proc = fleetctl("demo", "--time-scale", "6", "--log", tmp_path, env=headless(), timeout=150)
    out = proc.stdout
    assert proc.returncode == 0, out + proc.stderr
    assert re.search(r"^  robot 2 \(green\)", out, re.M)  # the plan summary is still there
    assert "stalls 8 s in its drive" in out and "demo console: start" in out
    assert "console: headless on a private Xvfb" in out
    folder = Path(re.search(r"^run folder: (.+)$", out, re.M).group(1))
    assert folder.parent == tmp_path
    summary = (folder / "summary.txt").read_text()
    assert "arrived: 5/5" in summary and "collisions: 0" in summary
    assert (folder / "events.jsonl").stat().st_size > 0
    report = (folder / "report.html").read_text()  # the run read back as `fleetctl report` reads it
    assert "Robots over time" in report and "arrived: 5/5" in report and "report.html" in out
    assert (folder / "report-gantt.png").stat().st_size > 0
    frames = sorted((folder / "frames").glob("*.png"))
    index = (folder / "frames" / "frames.txt").read_text().splitlines()
    assert len(frames) >= 10 and len(index) == len(frames) + 1
    assert index[1].split()[1] == "waiting" and index[-1].split()[1] == "done"
    # the presentation view's ticker told the story the visitor watched, in words
    stall = re.search(r"robot (\d) stalls 8 s in its drive", out)
    told = [t for line in index[1:] if "| " in line for t in line.split("| ", 1)[1].split(" ; ")]
    assert "the run starts: 5 robots" in told and "robot {} stalled".format(stall.group(1)) in told, told
    # and that others wait because of it: behind it, or behind a robot held up by it (which one
    # depends on where the stall finds the others, and so on the machine's load)
    assert any(re.fullmatch(r"robot \d (waits for|stops behind) robots? [\d, ]+", t) for t in told), told
    assert told[-1].startswith("every robot is home: done in") and told[-1].endswith("no collision")
    with Image.open(frames[-1]) as last:
        assert (last.width, last.height) == (1600, 1000)  # the presentation view, full screen
    assert all(gone(pid) for pid in pids(out))


def start_demo(folder: Path) -> Tuple["subprocess.Popen[str]", List[str]]:
    """The demo in its own session, and what it printed until its run was under way."""
    scratch = folder / "tmp"  # TMPDIR: what a killed demo cannot remove stays in the test's folder
    scratch.mkdir()
    demo = subprocess.Popen([sys.executable, "-m", "fleetctl", "demo", "--log", str(folder)],
                            env=dict(headless(), TMPDIR=str(scratch)),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            # as from a terminal: Ctrl-C is not ignored (a suite run in the background ignores it)
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    lines: List[str] = []
    try:
        assert demo.stdout is not None
        for line in demo.stdout:
            lines.append(line)
            if "demo console: start" in line:
                break
    except BaseException:
        demo.kill()
        demo.wait()
        raise
    return demo, lines


def test_ctrl_c_stops_every_process_the_demo_started(tmp_path: Path) -> None:
    demo, lines = start_demo(tmp_path)
    try:
        children = pids("".join(lines))
        os.kill(demo.pid, signal.SIGINT)
        rest, _ = demo.communicate(timeout=60)
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.wait()
    assert demo.returncode == 130, "".join(lines) + rest
    assert "interrupted: stopping the console, the manager and the fleet" in rest
    deadline = time.monotonic() + 5
    while not all(gone(pid) for pid in children) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert [pid for pid in children if not gone(pid)] == []
    assert list((tmp_path / "tmp").iterdir()) == []  # its scratch folders (plan, logs) removed too


def test_a_demo_killed_outright_takes_its_processes_along(tmp_path: Path) -> None:
    """SIGKILL (a test's timeout, the OOM killer) leaves the demo no chance to stop its children:
    the kernel tells them (and the console's Xvfb) that their parent died."""
    demo, lines = start_demo(tmp_path)
    try:
        children = pids("".join(lines))
        xvfb = [int(p) for c in children for p in Path("/proc/{}/task/{}/children".format(c, c))
                .read_text().split()] if children else []
        demo.kill()
        demo.wait(10)
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.wait()
    assert len(children) == 3 and xvfb, "".join(lines)
    deadline = time.monotonic() + 15
    while not all(gone(pid) for pid in children + xvfb) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert [pid for pid in children + xvfb if not gone(pid)] == []


def test_console_without_a_manager_says_so_in_its_screenshot(tmp_path: Path) -> None:
    port = free_port_block(1)
    png = tmp_path / "alone.png"
    proc = fleetctl("console", "--manager", "tcp://127.0.0.1:{}".format(port), "--no-curve",
                    "--screenshot", png, "--after", "1.5", env=headless())
    assert proc.returncode == 0, proc.stderr
    assert "{}: the console on tcp://127.0.0.1:{}".format(png, port) in proc.stdout
    with Image.open(png) as image:
        assert image.width > 1000


def test_console_takes_the_managers_endpoint_with_or_without_tcp(tmp_path: Path) -> None:
    from live import fleet_definitions, start_fleet, start_manager

    definitions, feedback, port = fleet_definitions(tmp_path, 5)
    procs = [start_fleet(tmp_path, definitions, feedback)]
    procs.append(start_manager(tmp_path, lab_instance_path(), definitions, port, "--no-log"))
    try:
        proc = fleetctl("console", "--manager", "127.0.0.1:{}".format(port), "--no-curve",
                        "--screenshot", tmp_path / "x.png", "--after", "3", env=headless())
    finally:
        for p in reversed(procs):
            p.stop()
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert "the console on tcp://127.0.0.1:{}".format(port) in proc.stdout
    assert "the run is waiting" in proc.stdout  # it talked to the manager


def test_console_errors_are_one_line(tmp_path: Path) -> None:
    for bad in ("tcp://nowhere", "127.0.0.1:99999", "udp://127.0.0.1:7100"):
        endpoint = fleetctl("console", "--manager", bad, "--no-curve", "--screenshot", tmp_path / "x.png",
                            env=headless())
        assert endpoint.returncode == 2 and endpoint.stderr.count("\n") == 1, endpoint.stderr
        assert "expected HOST:PORT or tcp://HOST:PORT" in endpoint.stderr
    window = fleetctl("console", "--no-curve", env=headless())
    assert window.returncode == 2 and window.stderr.count("\n") == 1
    assert "no display" in window.stderr and "--screenshot" in window.stderr
    keys = fleetctl("console", "--keys", tmp_path / "nokeys", "--screenshot", tmp_path / "x.png", env=headless())
    assert keys.returncode == 2 and keys.stderr.count("\n") == 1
    assert "console.key_secret" in keys.stderr and "--no-curve" in keys.stderr
