"""The packaging a newcomer meets first: pip install, `fleetctl`, catkin, the entry script.

These run the real tools (pip's installed script, catkin_pkg, catkin_make,
vermin, bash) from outside the repository, the way a user or CI would.
"""
from __future__ import annotations

import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import List

import pytest

BIN = Path(sys.executable).parent
FLEET_COMMON = Path("catkin_ws/src/fleet_common")


def run(args: List[str], cwd: Path, **kwargs: object) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=120, **kwargs)


def test_catkin_package_xml_declares_fleet_common(repo_root: Path) -> None:
    from catkin_pkg.package import parse_package

    import fleet_common

    package = parse_package(str(repo_root / FLEET_COMMON / "package.xml"))
    assert package.name == "fleet_common"
    assert package.package_format == 3
    assert list(package.licenses) == ["MIT"]
    assert [d.name for d in package.buildtool_depends] == ["catkin"]
    assert {d.name for d in package.exec_depends} >= {"python3-numpy", "python3-yaml"}
    # One version everywhere: catkin's, the Python package's and pip's.
    assert package.version == fleet_common.__version__ == metadata.version("fleetcontrol")


def test_installed_package_imports_from_elsewhere(repo_root: Path, tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = "import fleet_common, fleet_common.grid; print(fleet_common.__file__)"
    result = run([sys.executable, "-c", code], cwd=tmp_path, env=env)
    assert result.returncode == 0, result.stderr
    # An editable install: the code imported is the repository's own source tree.
    assert Path(result.stdout.strip()).parent == repo_root / FLEET_COMMON / "src" / "fleet_common"


def test_fleetctl_help_runs_from_elsewhere(tmp_path: Path) -> None:
    result = run([str(BIN / "fleetctl"), "--help"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: fleetctl")


def test_entry_scripts_are_executable(repo_root: Path) -> None:
    for script in ("scripts/ciirc-exec.sh", ".ci/run"):
        assert os.access(repo_root / script, os.X_OK), f"{script} lost its executable bit"


def test_ciirc_exec_lists_its_subcommands(repo_root: Path, tmp_path: Path) -> None:
    result = run([str(repo_root / "scripts" / "ciirc-exec.sh"), "--help"], cwd=tmp_path)
    assert result.returncode == 0
    for name in ("setup", "demo", "test"):
        assert f"\n  {name} " in result.stdout


def test_ciirc_exec_rejects_unknown_subcommand_in_one_line(repo_root: Path, tmp_path: Path) -> None:
    result = run([str(repo_root / "scripts" / "ciirc-exec.sh"), "bogus"], cwd=tmp_path)
    assert result.returncode == 2
    assert result.stdout == ""
    assert len(result.stderr.splitlines()) == 1
    assert "unknown subcommand 'bogus'" in result.stderr


def vermin(repo_root: Path, path: Path) -> subprocess.CompletedProcess:
    # The same configuration `ciirc-exec.sh test` uses (setup.cfg's [vermin] section).
    return run([str(BIN / "vermin"), "--config-file", str(repo_root / "setup.cfg"), str(path)], cwd=repo_root)


@pytest.mark.parametrize(
    "source, needs",
    [
        ("merged = {'a': 1} | {'b': 2}\n", "dict union"),
        ("import functools\n\n@functools.cache\ndef f():\n    return 1\n", "functools.cache"),
        ("def f(x):\n    match x:\n        case 1:\n            return 2\n", "pattern matching"),
        ("name = 'x.map'.removesuffix('.map')\n", "str.removesuffix"),
    ],
)
def test_python38_check_rejects_newer_code(repo_root: Path, tmp_path: Path, source: str, needs: str) -> None:
    (tmp_path / "robot_node.py").write_text(source)
    result = vermin(repo_root, tmp_path)
    assert result.returncode != 0
    assert needs in result.stdout


def test_python38_check_allows_postponed_annotations(repo_root: Path, tmp_path: Path) -> None:
    # Our rule: `list[int]` and `X | None` are fine inside annotations, thanks to the future import.
    (tmp_path / "robot_node.py").write_text(
        "from __future__ import annotations\n\n"
        "def f(cells: list[tuple[int, int]] | None) -> dict[str, int]:\n    return {}\n"
    )
    result = vermin(repo_root, tmp_path)
    assert result.returncode == 0, result.stdout


def test_robot_side_code_passes_python38_check(repo_root: Path) -> None:
    result = vermin(repo_root, repo_root / "catkin_ws" / "src")
    assert result.returncode == 0, result.stdout


def test_robot_side_modules_postpone_annotations(repo_root: Path) -> None:
    # Without it, an annotation such as `list[int]` raises at import time on Python 3.8.
    missing = [
        str(path.relative_to(repo_root))
        for path in sorted((repo_root / "catkin_ws" / "src").glob("*/src/**/*.py"))
        if path.read_text(encoding="utf-8").strip()
        and "from __future__ import annotations" not in path.read_text(encoding="utf-8")
    ]
    assert missing == []


def test_catkin_make_builds_an_importable_fleet_common(repo_root: Path, tmp_path: Path) -> None:
    build, devel = tmp_path / "build", tmp_path / "devel"
    result = run(
        # -C: catkin_make takes the workspace from $PWD, not from the process's directory.
        ["catkin_make", "-C", str(tmp_path), "--source", str(repo_root / "catkin_ws" / "src"), "--build", str(build),
         "-DPYTHON_EXECUTABLE=/usr/bin/python3", f"-DCATKIN_DEVEL_PREFIX={devel}"],
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    # What a robot gets: Debian's python3, no venv, only catkin's devel space on the path.
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(devel / "lib" / "python3" / "dist-packages")}
    code = "import fleet_common.grid, fleet_common; print(fleet_common.__version__)"
    imported = run(["/usr/bin/python3", "-c", code], cwd=tmp_path, env=env)
    assert imported.returncode == 0, imported.stderr


def test_every_module_folder_is_a_regular_package(repo_root: Path) -> None:
    # setup.py finds subpackages by their __init__.py; a folder without one would work in the
    # editable install but be missing from a wheel and from catkin's install space.
    roots = sorted(repo_root.glob("catkin_ws/src/*/src/*")) + [repo_root / "fleetctl"]
    folders = {py.parent for root in roots if root.is_dir() for py in root.rglob("*.py")}
    missing = sorted(str(d.relative_to(repo_root)) for d in folders if not (d / "__init__.py").is_file())
    assert missing == []


def test_setup_puts_fleetctl_on_the_path_so_readme_examples_work_as_typed(repo_root: Path, tmp_path: Path) -> None:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    env = dict(os.environ, FLEETCONTROL_BIN_DIR=str(bin_dir))
    result = run([str(repo_root / "scripts" / "ciirc-exec.sh"), "setup"], cwd=tmp_path, env=env)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"fleetctl: {bin_dir}/fleetctl -> {repo_root}/.venv/bin/fleetctl" in result.stdout
    # a shell with only the system folders and that one on its PATH, elsewhere: `fleetctl ...` as typed
    typed = run(["bash", "-c", "fleetctl info lab.map"], cwd=repo_root / FLEET_COMMON / "src" / "fleet_common" / "lab",
                env={"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(tmp_path)})
    assert typed.returncode == 0, typed.stderr
    assert "13 x 14" in typed.stdout or "13x14" in typed.stdout, typed.stdout
    again = run([str(repo_root / "scripts" / "ciirc-exec.sh"), "setup"], cwd=tmp_path, env=env)
    assert f"fleetctl: on the PATH ({bin_dir}/fleetctl)" in again.stdout
