"""Hostile files: every reader turns any input into a value or our own error, and every file
case of issue 11 reaches the user as one line.

Fuzz: arbitrary text and mutations of real files (mapf-IR's maps, instances and
solutions, the lab's files, legacy XML, robot definitions, YAML frames) never raise
anything but a FleetError. Command line: a 5,000-digit integer in any header or agent
line, a 3 MB value, a CR inside a bad value, a 50 MB instance broken at line 33: exit 2,
one line under 300 characters naming the file and line, no traceback. README: "Nothing
is skipped silently": a header key nobody knows is a warning naming its line and the
nearest known key, and the exit status stays what it was.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Callable, Dict

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.errors import FleetError
from fleet_common.formats.instance import parse_instance
from fleet_common.formats.legacy_xml import parse_legacy_node_map, parse_legacy_plan
from fleet_common.formats.mapfile import parse_map
from fleet_common.formats.scen import parse_scen
from fleet_common.formats.solution import parse_solution
from fleet_common.frames import parse_transforms
from fleet_common.grid import Grid
from fleet_common.lab import lab_frames_path, lab_nodes_path, lab_transforms
from fleet_common.lab.node_table import parse_node_table
from fleet_common.robots import parse_robot_definitions
from fleetctl.cli import main
from helpers import big_broken_instance

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "data" / "mapf-ir"
LEGACY = REPO / "tests" / "data" / "legacy"
OPEN = Grid(np.ones((40, 40), dtype=bool))
BIG = "9" * 5000
SCEN = "version 1\n0\tarena.map\t49\t49\t1\t1\t3\t3\t2.82842712\n1\tarena.map\t49\t49\t4\t4\t6\t7\t5\n"
TO_METRES = lab_transforms()["base_to_robot"]

# reader name -> (parse text -> value, sample texts)
READERS: Dict[str, tuple] = {
    "map": (parse_map, [SHARED / "maps" / "random-32-32-20.map", SHARED / "maps" / "tunnel.map"]),
    "instance": (lambda t: parse_instance(t, "i.txt", grid=OPEN),
                 [SHARED / "instances" / "random-32-32-20_30agents_1.txt",
                  SHARED / "instances" / "sample.txt"]),
    "solution": (lambda t: parse_solution(t, "s.txt", grid=OPEN),
                 [SHARED / "solutions" / "cbs_makespan-soc-pareto.txt",
                  SHARED / "solutions" / "ir_makespan-soc-pareto.txt"]),
    "scen": (parse_scen, [SCEN]),
    "legacy plan": (lambda t: parse_legacy_plan(t.encode("utf-8", "surrogateescape")),
                    [LEGACY / "lab_plan.xml", LEGACY / "thesis_fig3_1_plan.xml"]),
    "legacy nodes": (lambda t: parse_legacy_node_map(t.encode("utf-8", "surrogateescape")),
                     [LEGACY / "lab_nodes.xml"]),
    "robot definitions": (parse_robot_definitions, [REPO / "robot_definitions.txt"]),
    "frames": (parse_transforms, [lab_frames_path()]),
    "node table": (lambda t: parse_node_table(t, "nodes.yaml", TO_METRES), [lab_nodes_path()]),
}
PIECES = ["9" * 5000, "1e999", "-", ",", "=", "(", ")", ":", "\r", "\r\n", "\n", "\x00",
          "\udcff", "map", "height 3", "agents=", "starts=", "solution=", "<", ">", "\"",
          "[" * 300, "{", "&a;", "\t", " ", "x" * 3000, "#", "NaN", "0:", "@"]


def samples(kind: str) -> list:
    return [s if isinstance(s, str) else s.read_text(encoding="utf-8")
            for s in READERS[kind][1]]


def read_quietly(parse: Callable[[str], object], text: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            parse(text)
        except FleetError as err:
            assert "\n" not in str(err) and "\r" not in str(err), repr(str(err))
            assert len(str(err)) < 600, str(err)[:200]


@pytest.mark.parametrize("kind", sorted(READERS))
@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_mutated_files_give_a_value_or_our_error(kind: str, data: st.DataObject) -> None:
    text = data.draw(st.sampled_from(samples(kind)))
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, len(text)))
        cut = data.draw(st.integers(0, 8))
        text = text[:at] + data.draw(st.sampled_from(PIECES)) + text[at + cut:]
    read_quietly(READERS[kind][0], text)


@pytest.mark.parametrize("kind", sorted(READERS))
@settings(max_examples=60)
@given(raw=st.binary(max_size=400))
def test_any_bytes_give_a_value_or_our_error(kind: str, raw: bytes) -> None:
    read_quietly(READERS[kind][0], raw.decode("utf-8", "surrogateescape"))


@pytest.mark.parametrize("encoding", ["x-unknown", "rot13", "base64", "shift_jis", "utf-32", "idna",
                                      "undefined", "punycode", "mbcs"])
def test_an_xml_declaration_naming_an_unreadable_encoding_is_our_error_at_line_1(encoding: str) -> None:
    """Found by the fuzz test above (rarely): expat asks Python's codecs for the encoding the
    declaration names, and they raise LookupError, ValueError or UnicodeError."""
    data = '<?xml version="1.0" encoding="{}"?>\n<plan>\xe9</plan>\n'.format(encoding).encode("latin-1")
    for parse in (parse_legacy_plan, parse_legacy_node_map):
        with pytest.raises(FleetError) as caught:
            parse(data, "plan.xml")
        assert str(caught.value).startswith("plan.xml:1: the encoding its XML declaration names cannot be read")


# ---- the command line, as the issue found it -------------------------------------------------

def run(*args: object) -> tuple:
    """fleetctl in this process: (exit status, stdout, stderr)."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in args])
    return status, out.getvalue(), err.getvalue()


def assert_one_line(status: int, stderr: str, path: Path, line: int, fragment: str) -> None:
    assert status == 2, stderr
    assert stderr.endswith("\n") and stderr.count("\n") == 1, repr(stderr[:400])
    assert len(stderr) < 300 and "Traceback" not in stderr
    assert stderr.startswith("{}:{}:".format(path, line)), stderr
    assert fragment in stderr, stderr


@pytest.fixture
def files(tmp_path: Path) -> Path:
    shutil.copy(SHARED / "maps" / "makespan-soc-pareto.map", tmp_path / "p.map")
    return tmp_path


INSTANCE = "map_file=p.map\nagents=2\nseed=0\nmax_timestep=100\n3,1,4,1\n1,3,5,1\n"
SOLUTION = (SHARED / "solutions" / "cbs_makespan-soc-pareto.txt").read_text()
CASES = [
    # (file name, text, command, line, fragment)
    ("i.txt", INSTANCE.replace("agents=2", "agents=" + BIG), "info", 2, "at most 18 digits"),
    ("i.txt", INSTANCE.replace("seed=0", "seed=" + BIG), "info", 3, "at most 18 digits"),
    ("i.txt", INSTANCE.replace("3,1,4,1", "3,{},4,1".format(BIG)), "info", 5,
     "coordinate with more than 9 digits"),
    ("s.txt", SOLUTION.replace("soc=13", "soc=" + BIG), "validate", 6, "at most 18 digits"),
    ("s.txt", SOLUTION.replace("agents=2", "agents=" + BIG), "validate", 2, "at most 18 digits"),
    ("s.txt", SOLUTION.replace("comp_time=0", "comp_time=1" + "0" * 400), "validate", 10,
     "'comp_time=' must be a number"),
    ("s.txt", SOLUTION.replace("5:(4,1),(2,1),", "5:(4,1),({},1),".format(BIG)), "validate", 19,
     "coordinate with more than 9 digits"),
    ("s.txt", SOLUTION.replace("starts=(3,1)", "starts=({},1)".format(BIG)), "validate", 11,
     "coordinate with more than 9 digits"),
    ("m.map", "type octile\nheight {}\nwidth 6\nmap\n......\n".format(BIG), "info", 2,
     "more than 9 digits"),
    ("x.scen", SCEN.replace("0\tarena", BIG + "\tarena"), "info", 2, "at most 9 digits"),
    ("r.txt", "{} 10.0.0.1 10001 u v red\n".format(BIG), "info", 1, "bad id '999"),
    ("r.txt", "1 10.0.0.1 {} u v red\n".format(BIG), "info", 1, "bad command_port '999"),
    ("x.xml", '<plan><agent id="{}"/></plan>'.format(BIG), "info", 1, "expected an integer"),
    # a huge value is quoted, not echoed whole
    ("i.txt", INSTANCE.replace("agents=2", "agents=" + "x" * 3_000_000), "info", 2,
     "(3,000,000 characters)"),
    ("i.txt", INSTANCE + "?" * 3_000_000 + "\n", "info", 7, "(3,000,000 characters)"),
    ("s.txt", SOLUTION.replace("solver=CBS", "solver CBS" + "x" * 3_000_000), "validate", 4,
     "(3,000,010 characters)"),
    # a CR inside a bad value does not break the line
    ("i.txt", INSTANCE.replace("agents=2", "agents=2\r7"), "info", 2, "got '2\\r7'"),
    ("s.txt", SOLUTION.replace("makespan=12", "makespan=1\r2"), "validate", 8, "got '1\\r2'"),
    ("m.map", "type octile\nheight 4\rwidth 6\nmap\n", "info", 2, "got 'height 4\\rwidth 6'"),
    ("r.txt", "1 10.0.0.1 10001 u v\x1b[2J red\n", "info", 1, "bad vicon_name 'v\\x1b[2J'"),
]


@pytest.mark.parametrize("name, text, command, line, fragment", CASES,
                         ids=["{}-{}".format(c[0], i) for i, c in enumerate(CASES)])
def test_each_bad_file_is_one_line_naming_file_and_line(files: Path, name: str, text: str,
                                                        command: str, line: int,
                                                        fragment: str) -> None:
    path = files / name
    path.write_bytes(text.encode("utf-8"))
    status, _, stderr = run(command, path)
    assert_one_line(status, stderr, path, line, fragment)


# every file a command takes that is not a plan file: bytes that are not text, a folder
BINARY = b"plans:\n  - \xff\xfe\n"
NOT_PLAN_FILES = [
    ("experiment", lambda f: ("experiment", f)),
    ("results table", lambda f: ("report", f)),
    ("delay model", lambda f: ("simulate", SHARED / "solutions" / "cbs_makespan-soc-pareto.txt",
                               "--map-dir", SHARED / "maps", "--delay-model", f)),
]


@pytest.mark.parametrize("kind, args", NOT_PLAN_FILES, ids=[k for k, _ in NOT_PLAN_FILES])
def test_a_spec_table_or_model_file_that_is_not_text_is_one_line_naming_file_and_byte(
        tmp_path: Path, kind: str, args: Callable[[Path], tuple]) -> None:
    path = tmp_path / ("f.csv" if kind == "results table" else "f.yaml")
    path.write_bytes(BINARY)
    status, _, stderr = run(*args(path))
    assert_one_line(status, stderr, path, 2, "byte 0xff is not UTF-8 text")
    folder = tmp_path / "folder.yaml"
    folder.mkdir()
    status, _, stderr = run(*args(folder))
    assert status == 2 and stderr.count("\n") == 1 and "Traceback" not in stderr, stderr
    assert str(folder) in stderr, stderr


def test_a_deploy_config_that_is_not_text_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "deploy.yaml"
    path.write_bytes(b"repository: /srv/f\xffleet.git\n")
    result = subprocess.run([sys.executable, "-m", "deploy", "robots:status", "--config", str(path)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr == "{}:1:19: byte 0xff is not UTF-8 text\n".format(path)


def test_misspelled_header_keys_are_warnings_naming_line_and_nearest_key(files: Path) -> None:
    solution = files / "s.txt"
    solution.write_text(SOLUTION.replace("lb_soc=9", "LB_SOC=9").replace(
        "makespan=12\n", "makespan=12\nmakespan_typo=3\n"))
    shutil.copy(SHARED / "instances" / "makespan-soc-pareto.txt", files / "x.txt")
    status, out, err = run("validate", solution)
    assert status == 0 and ": valid:" in out  # the exit status of a valid plan, unchanged
    assert err.splitlines() == [
        "{}:7: warning: unknown key 'LB_SOC' (did you mean 'lb_soc'?) in a solution; mapf-IR "
        "ignores it, and so does FleetControl".format(solution),
        "{}:9: warning: unknown key 'makespan_typo' (did you mean 'makespan'?) in a solution; "
        "mapf-IR ignores it, and so does FleetControl".format(solution)]
    instance = files / "i.txt"
    instance.write_text(INSTANCE.replace("max_timestep=100", "max_titep=100"))
    status, out, err = run("info", instance)
    assert status == 0 and "instance: 2 agents" in out
    assert err == ("{}:4: warning: unknown key 'max_titep' (did you mean 'max_timestep'?) in an "
                   "instance; mapf-IR ignores it, and so does FleetControl\n".format(instance))
    complete = files / "c.txt"  # a key real mapf-IR solvers write (PIBT_COMPLETE) is no typo
    complete.write_text(SOLUTION.replace("makespan=12\n", "makespan=12\ncomp_time_complement=0\n"))
    status, out, err = run("validate", complete)
    assert status == 0 and err == ""
    bad = files / "b.txt"  # a warning does not hide the error that follows it
    bad.write_text(INSTANCE.replace("max_timestep=100", "max_titep=100").replace("1,3,5,1", "1,3"))
    status, _, err = run("info", bad)
    assert_one_line(status, err, bad, 6, "expected ',' after sy")


# ---- a 50 MB instance broken at line 33, in a real process (timing: bench/hostile_files.py) ---

def test_a_50_mb_instance_broken_at_line_33_is_refused_in_little_memory(tmp_path: Path) -> None:
    path = big_broken_instance(tmp_path / "big.txt")
    probe = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], "
             "capture_output=True, text=True); print(p.returncode); print(resource.getrusage("
             "resource.RUSAGE_CHILDREN).ru_maxrss); sys.stderr.write(p.stderr)")
    proc = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "fleetctl", "info",
                           str(path)], capture_output=True, text=True, timeout=120)
    status, max_rss_kb = (int(v) for v in proc.stdout.split())
    assert_one_line(status, proc.stderr, path, 33, "start (99,5) of agent 27 is off the map")
    assert max_rss_kb < 200 * 1024, "{} MB".format(max_rss_kb // 1024)
