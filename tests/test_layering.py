"""The import graph keeps its layers: no circle, no arrow upwards.

Every module of console, evaluation, fleetctl, virtual_fleet, deploy, bench,
experiments and the three catkin packages is read with `ast` (nothing is
imported), and each import becomes an arrow, also those under `if
TYPE_CHECKING:` and inside functions: an import that only runs later is a
dependency all the same. `from a.b import c` points at module `a.b.c` when there
is one, else at `a.b`; a package's `__init__` is not implied by importing one of
its modules (re-exporting `__init__` files would otherwise close circles that do
not exist at run time).

The layers, bottom up: fleet_common (pure core, the protocols); agv_package (the
robot) and virtual_fleet; fleet_manager; console (speaks only the console
protocol); evaluation; fleetctl on top, with deploy and bench beside it. A failure
names the circle or the arrow with the file and line of each import.
"""
from __future__ import annotations

import ast
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, FrozenSet, Iterable, List, Optional, Sequence, Set, Tuple

import pytest

#: Top-level package -> folder holding it, relative to the repository.
ROOTS: Dict[str, str] = {
    "fleet_common": "catkin_ws/src/fleet_common/src/fleet_common",
    "agv_package": "catkin_ws/src/agv_package/src/agv_package",
    "fleet_manager": "catkin_ws/src/fleet_manager/src/fleet_manager",
    "virtual_fleet": "virtual_fleet",
    "console": "console",
    "evaluation": "evaluation",
    "fleetctl": "fleetctl",
    "deploy": "deploy",
    "bench": "bench",
    "experiments": "experiments",
}
#: Catkin executables (Python without a .py name), read as modules `<package>.nodes.<name>`.
NODES = ("catkin_ws/src/agv_package/nodes", "catkin_ws/src/fleet_manager/nodes")
OURS = frozenset(ROOTS)

#: Package -> the packages of ours it must not import, and why.
FORBIDDEN: Dict[str, Tuple[FrozenSet[str], str]] = {
    "fleet_common": (OURS - {"fleet_common"}, "fleet_common is the bottom layer and imports nothing of ours"),
    "agv_package": (frozenset({"fleet_manager", "console", "fleetctl", "evaluation", "virtual_fleet"}),
                    "the robot side uses fleet_common only"),
    "fleet_manager": (frozenset({"console", "fleetctl", "evaluation", "virtual_fleet", "agv_package"}),
                      "the manager speaks to robots and consoles through fleet_common's protocols"),
    "console": (frozenset({"fleet_manager", "evaluation", "fleetctl"}),
                "the console knows the manager only through the console protocol"),
    "evaluation": (frozenset({"fleetctl"}), "fleetctl is the top layer; evaluation sits below it"),
    "virtual_fleet": (frozenset({"fleet_manager", "console", "fleetctl", "evaluation"}),
                      "virtual robots stand in for robots: they know neither the manager, the console nor the tools"),
}

@dataclass
class Graph:
    files: Dict[str, Path] = field(default_factory=dict)
    #: module -> imported module -> (file, line) of the first such import
    arrows: Dict[str, Dict[str, Tuple[Path, int]]] = field(default_factory=dict)


def module_files(repo: Path, roots: Dict[str, str], nodes: Sequence[str] = ()) -> Dict[str, Path]:
    files: Dict[str, Path] = {}
    for name, folder in roots.items():
        base = repo / folder
        for path in sorted(base.rglob("*.py")):
            parts = [name, *path.relative_to(base).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts.pop()
            files[".".join(parts)] = path
    for folder in nodes:
        package = Path(folder).parent.name
        for path in sorted((repo / folder).iterdir()):
            if path.is_file() and path.read_bytes().startswith(b"#!/usr/bin/env python"):
                files["{}.nodes.{}".format(package, path.name)] = path
    return files


def build_graph(files: Dict[str, Path]) -> Graph:
    graph = Graph(files=files)

    def known(name: str) -> Optional[str]:
        while name and name not in files:
            name = name.rpartition(".")[0]
        return name or None

    for module, path in files.items():
        is_package = path.name == "__init__.py"
        package = module if is_package else module.rpartition(".")[0]
        out = graph.arrows.setdefault(module, {})
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: List[Optional[str]] = []
            if isinstance(node, ast.Import):
                targets = [known(a.name) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    parts = package.split(".")
                    parts = parts[:len(parts) - node.level + 1]
                    base = ".".join(parts + ([node.module] if node.module else []))
                else:
                    base = node.module or ""
                targets = [known(base + "." + a.name) if base + "." + a.name in files else known(base)
                           for a in node.names]
            for target in targets:
                if target is not None and target != module and target not in out:
                    out[target] = (path, node.lineno)
    return graph


def circles(graph: Graph) -> List[List[str]]:
    """The strongly connected components of more than one module (Tarjan, without recursion)."""
    index: Dict[str, int] = {}
    low: Dict[str, int] = {}
    stack: List[str] = []
    on_stack: Set[str] = set()
    found: List[List[str]] = []
    counter = 0
    for root in sorted(graph.arrows):
        if root in index:
            continue
        work: List[Tuple[str, Iterable[str]]] = []
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        work.append((root, iter(sorted(graph.arrows[root]))))
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.arrows.get(w, {})))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def describe_circle(graph: Graph, component: Sequence[str], repo: Path) -> str:
    """One cycle through the component's first module, each arrow with its file and line."""
    inside = set(component)
    start = component[0]
    came_from: Dict[str, str] = {}
    queue = deque([start])
    while queue:
        v = queue.popleft()
        for w in sorted(graph.arrows[v]):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(came_from[path[-1]])
                path.reverse()
                steps = []
                for a, b in zip(path, path[1:] + [start]):
                    file, line = graph.arrows[a][b]
                    steps.append("{} -> {} ({}:{})".format(a, b, file.relative_to(repo), line))
                return "circle among {}: {}".format(", ".join(component), "; ".join(steps))
            if w in inside and w not in came_from:
                came_from[w] = v
                queue.append(w)
    return "circle among " + ", ".join(component)  # pragma: no cover  (an SCC always has a cycle)


def upward_arrows(graph: Graph, repo: Path) -> List[str]:
    found = []
    for module, out in sorted(graph.arrows.items()):
        top = module.split(".")[0]
        banned, why = FORBIDDEN.get(top, (frozenset(), ""))
        for target, (file, line) in sorted(out.items()):
            if target.split(".")[0] in banned:
                found.append("{}:{}: {} imports {} ({})".format(file.relative_to(repo), line, module, target, why))
    return found


def problems(repo: Path) -> List[str]:
    graph = build_graph(module_files(repo, ROOTS, NODES))
    found = [describe_circle(graph, c, repo) for c in circles(graph)]
    return found + upward_arrows(graph, repo)


# ---- the repository ----------------------------------------------------------------------

def test_the_repository_has_no_import_circle_and_no_upward_arrow(repo_root: Path) -> None:
    found = problems(repo_root)
    assert not found, "\n".join(found)


def test_the_graph_sees_every_package_and_the_imports_hidden_in_functions(repo_root: Path) -> None:
    graph = build_graph(module_files(repo_root, ROOTS, NODES))
    tops = {m.split(".")[0] for m in graph.files}
    assert tops == OURS - {"experiments"}  # experiments holds YAML only, today
    assert "agv_package.nodes.agv_runner" in graph.files
    # fleetctl's commands import their work inside `run` (start-up time): still arrows
    assert "evaluation.sweep" in graph.arrows["fleetctl.commands.experiment"]
    # and so are the imports for annotations only (under `if TYPE_CHECKING:`)
    assert "console.ui.live_app" in graph.arrows["console.live_console"]
    # relative imports resolve to modules
    assert "fleet_common.wire.codec" in graph.arrows["fleet_common.transport.pose_feedback"]


# ---- the checker itself, on small made-up trees ---------------------------------------------

def _tree(tmp_path: Path, files: Dict[str, str]) -> Path:
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tmp_path


@pytest.mark.parametrize("where", ["top", "function", "type_checking"])
def test_a_circle_is_found_however_the_import_is_written(tmp_path: Path, where: str) -> None:
    back = {
        "top": "from .app import App\n",
        "function": "def f():\n    from .app import App\n",
        "type_checking": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .app import App\n",
    }[where]
    repo = _tree(tmp_path, {"console/__init__.py": "", "console/ui/__init__.py": "",
                            "console/ui/app.py": "from . import actions\n",
                            "console/ui/actions.py": back})
    graph = build_graph(module_files(repo, {"console": "console"}))
    assert circles(graph) == [["console.ui.actions", "console.ui.app"]]
    text = describe_circle(graph, ["console.ui.actions", "console.ui.app"], repo)
    assert "console.ui.app -> console.ui.actions (console/ui/app.py:1)" in text
    assert "console.ui.actions -> console.ui.app (console/ui/actions.py:" in text


def test_an_upward_arrow_is_named_with_its_file_and_line(tmp_path: Path) -> None:
    repo = _tree(tmp_path, {"evaluation/__init__.py": "", "fleetctl/__init__.py": "",
                            "fleetctl/children.py": "",
                            "evaluation/cell.py": "import json\n\ndef run():\n    import fleetctl.children\n"})
    graph = build_graph(module_files(repo, {"evaluation": "evaluation", "fleetctl": "fleetctl"}))
    assert upward_arrows(graph, repo) == [
        "evaluation/cell.py:4: evaluation.cell imports fleetctl.children (fleetctl is the top layer; "
        "evaluation sits below it)"]
