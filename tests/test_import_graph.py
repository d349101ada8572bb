"""The package's import graph: no cycles, and the policy side never imports the robot side.

Every ``import`` / ``from ... import`` statement under ``legato_drake/`` counts, at module
level or inside a function (a lazy import is still an import), under ``TYPE_CHECKING`` too.
``import a.b.c`` is an edge to ``a.b.c`` and to its packages ``a.b`` and ``a``; ``from a.b
import c`` is an edge to ``a.b`` (and its packages) and, when ``a.b.c`` is a module, to it.
An edge from a module to a package that contains it is not counted (a module is always
imported as part of its package: that is containment, not a dependency).

Run as a script (``python tests/test_import_graph.py``) to print the cycles and forbidden
edges instead of asserting.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "legato_drake"

POLICY_SIDE = ("legato_drake.data", "legato_drake.learning", "legato_drake.invariants")
"""Modules (and packages: everything under them) that must not know the robot."""
ROBOT_SIDE = ("legato_drake.embodiments", "legato_drake.systems", "legato_drake.tasks",
              "legato_drake.diagram", "legato_drake.episode", "legato_drake.scenario",
              "legato_drake.pipelines", "legato_drake.executor", "legato_drake.experiment",
              "legato_drake.envs")
"""What the policy side must not import (packages: everything under them too)."""
TOP = (("legato_drake.experiment", ("legato_drake.cli",)), ("legato_drake.envs", ()))
"""Layers that only the named modules may import (the experiment and the Gymnasium
environments sit above the pipelines and the episode: nothing below them knows them)."""
CORE = ("legato_drake.conventions", "legato_drake.dimensions", "legato_drake.robot_types",
        "legato_drake.leg_kinematics", "legato_drake.poses", "legato_drake.summary",
        "legato_drake.files", "legato_drake.errors", "legato_drake.progress",
        "legato_drake.models")
"""The bottom layer (README, Architecture): imports nothing of the package but itself."""
APART = (("legato_drake.embodiments", "legato_drake.systems"),)
"""Pairs of packages that import nothing of each other (robots are data, systems are
systems: what both need lives in ``robot_types`` and ``leg_kinematics``)."""


def _within(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def module_files(root: Path = ROOT) -> dict[str, Path]:
    """Module name -> file of every module of the package (``__init__.py``: the package)."""
    modules = {}
    for path in sorted((root / PACKAGE).rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def _targets(node: ast.Import | ast.ImportFrom, module: str, is_package: bool,
             modules: dict[str, Path]) -> Iterator[tuple[str, int]]:
    """The package modules an import statement names (with its line number)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            base = module.split(".") if is_package else module.split(".")[:-1]
            base = base[:len(base) - (node.level - 1)]
            origin = ".".join([*base, *([node.module] if node.module else [])])
        else:
            origin = node.module or ""
        names = [origin] + [f"{origin}.{alias.name}" for alias in node.names
                            if f"{origin}.{alias.name}" in modules]
    for name in names:
        parts = name.split(".")
        for i in range(1, len(parts) + 1):  # a.b.c imports a, a.b and a.b.c
            target = ".".join(parts[:i])
            if target in modules:
                yield target, node.lineno


def import_graph(root: Path = ROOT) -> dict[str, dict[str, int]]:
    """Module -> {imported package module: first line of such an import}."""
    modules = module_files(root)
    graph: dict[str, dict[str, int]] = {}
    for module, path in modules.items():
        edges: dict[str, int] = {}
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                for target, line in _targets(node, module, path.name == "__init__.py",
                                             modules):
                    if target == module or module.startswith(target + "."):
                        continue  # itself, or a package that contains it
                    edges.setdefault(target, line)
        graph[module] = edges
    return graph


def cyclic_components(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:  # recursion depth is bounded by the package's size
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(components)


def find_cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """One import cycle per strongly connected component (the shortest through its first
    module), sorted."""
    return sorted(_cycle_through(graph, c) for c in cyclic_components(graph))


def _cycle_through(graph: dict[str, dict[str, int]], component: list[str]) -> list[str]:
    """One cycle (first module repeated at the end) inside a strongly connected component."""
    members = set(component)
    start = component[0]
    paths = {start: [start]}
    frontier = [start]
    while frontier:  # breadth-first: the shortest way back to start
        nxt = []
        for v in frontier:
            for w in sorted(graph[v]):
                if w == start:
                    return [*paths[v], start]
                if w in members and w not in paths:
                    paths[w] = [*paths[v], w]
                    nxt.append(w)
        frontier = nxt
    return [*component, start]


def forbidden_edges(graph: dict[str, dict[str, int]], root: Path = ROOT) -> list[str]:
    """``file:line: module -> target`` for every policy-side import of the robot side."""
    modules = module_files(root)
    return [f"{modules[m].relative_to(root)}:{line}: {m} -> {t}"
            for m, edges in sorted(graph.items()) if _within(m, POLICY_SIDE)
            for t, line in sorted(edges.items()) if _within(t, ROBOT_SIDE)]


def layer_violations(graph: dict[str, dict[str, int]]) -> list[str]:
    """``module -> target`` for every core module importing above the core, every import of
    a top layer from below it, and every edge between two packages kept apart."""
    found = [f"{m} -> {t}" for m, edges in sorted(graph.items()) if _within(m, CORE)
             for t in sorted(edges) if t != PACKAGE and not _within(t, CORE)]
    for top, users in TOP:
        found += [f"{m} -> {t}" for m, edges in sorted(graph.items()) for t in sorted(edges)
                  if _within(t, (top,)) and not _within(m, (top, *users))]
    for a, b in APART:
        found += [f"{m} -> {t}" for m, edges in sorted(graph.items())
                  for t in sorted(edges)
                  if (_within(m, (a,)) and _within(t, (b,)))
                  or (_within(m, (b,)) and _within(t, (a,)))]
    return found


def forbidden_paths(graph: dict[str, dict[str, int]]) -> list[str]:
    """``a -> b -> c`` for every policy-side module that reaches the robot side through
    other modules (e.g. a shared helper that imports a registry)."""
    found = []
    for start in sorted(m for m in graph if _within(m, POLICY_SIDE)):
        paths = {start: [start]}
        frontier = [start]
        while frontier:  # breadth-first: the shortest such chain
            nxt = []
            for v in frontier:
                for w in sorted(graph[v]):
                    if w not in paths:
                        paths[w] = [*paths[v], w]
                        nxt.append(w)
            frontier = nxt
        reached = sorted((len(p), p) for m, p in paths.items() if _within(m, ROBOT_SIDE))
        if reached and len(reached[0][1]) > 2:  # direct edges: forbidden_edges
            found.append(" -> ".join(reached[0][1]))
    return found


def _describe(graph: dict[str, dict[str, int]], cycle: list[str]) -> str:
    modules = module_files()
    return " -> ".join(cycle) + "  (" + ", ".join(
        f"{modules[a].relative_to(ROOT)}:{graph[a][b]}" for a, b in zip(cycle, cycle[1:],
                                                                         strict=False)) + ")"


def test_the_checker_sees_lazy_relative_and_indirect_imports(tmp_path):
    files = {"__init__.py": "", "data/__init__.py": "", "tasks/__init__.py": "",
             "tasks/lid.py": "",
             "data/a.py": "def f():\n    from legato_drake import diagram\n",
             "diagram.py": "import legato_drake.data.a\n",
             "episode.py": "from .data import a\n",
             "helper.py": "from legato_drake.tasks import lid\n",
             "data/b.py": "import legato_drake.helper\n",
             "conventions.py": "from legato_drake.tasks import lid\n",
             "experiment/__init__.py": "", "experiment/runner.py": "",
             "cli.py": "from legato_drake.experiment import runner\n",
             "pipelines.py": "import legato_drake.experiment.runner\n"}
    for name, text in files.items():
        (tmp_path / PACKAGE / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / PACKAGE / name).write_text(text)
    graph = import_graph(tmp_path)
    assert graph["legato_drake.data.a"] == {"legato_drake.diagram": 2}
    assert set(graph["legato_drake.diagram"]) == {"legato_drake.data",
                                                  "legato_drake.data.a"}
    assert set(graph["legato_drake.episode"]) == {"legato_drake.data", "legato_drake.data.a"}
    assert find_cycles(graph) == [["legato_drake.data.a", "legato_drake.diagram",
                                   "legato_drake.data.a"]]
    assert forbidden_edges(graph, tmp_path) == [
        "legato_drake/data/a.py:2: legato_drake.data.a -> legato_drake.diagram"]
    assert forbidden_paths(graph) == [
        "legato_drake.data.b -> legato_drake.helper -> legato_drake.tasks"]
    assert layer_violations(graph) == ["legato_drake.conventions -> legato_drake.tasks",
                                       "legato_drake.conventions -> legato_drake.tasks.lid",
                                       "legato_drake.pipelines -> legato_drake.experiment",
                                       "legato_drake.pipelines -> "
                                       "legato_drake.experiment.runner"]


def test_the_package_has_no_import_cycles():
    graph = import_graph()
    components = cyclic_components(graph)
    assert not components, "import cycles:\n" + "\n".join(
        f"{_describe(graph, _cycle_through(graph, c))}; all of {', '.join(c)}"
        for c in components)


def test_the_policy_side_imports_nothing_of_the_robot_side():
    graph = import_graph()
    edges = forbidden_edges(graph)
    assert not edges, ("data/, learning/ and invariants.py must not import the robot side "
                       "(README, Architecture):\n" + "\n".join(edges))
    paths = forbidden_paths(graph)
    assert not paths, ("data/, learning/ and invariants.py reach the robot side through "
                       "other modules:\n" + "\n".join(paths))



def test_training_a_policy_needs_no_drake():
    """The learning package runs where Drake is not installed (a GPU training box): importing
    every one of its modules, and what they import, loads no ``pydrake``."""
    learning = sorted(m for m in module_files() if _within(m, ("legato_drake.learning",)))
    code = ("import importlib, sys\n"
            f"for name in {learning!r}:\n"
            "    importlib.import_module(name)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'pydrake'))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=ROOT, check=True)
    assert result.stdout.strip() == "[]", f"legato_drake.learning loads {result.stdout}"

def test_the_core_stays_at_the_bottom_and_robots_and_systems_apart():
    violations = layer_violations(import_graph())
    assert not violations, ("the core imports only the core, and embodiments/ and systems/ "
                            "never each other (README, Architecture):\n"
                            + "\n".join(violations))


if __name__ == "__main__":
    graph = import_graph()
    components = cyclic_components(graph)
    edges = forbidden_edges(graph)
    paths = forbidden_paths(graph)
    layers = layer_violations(graph)
    print(f"{len(graph)} modules, {sum(len(e) for e in graph.values())} edges")
    print(f"import cycles (strongly connected groups of modules): {len(components)}")
    for component in components:
        print(f"  {_describe(graph, _cycle_through(graph, component))}")
        print(f"    all of: {', '.join(component)}")
    print(f"forbidden policy-side -> robot-side imports: {len(edges)}")
    for edge in edges:
        print("  " + edge)
    print(f"policy-side modules reaching the robot side through others: {len(paths)}")
    for path in paths:
        print("  " + path)
    print(f"core or embodiments/systems layer violations: {len(layers)}")
    for layer in layers:
        print("  " + layer)
    sys.exit(1 if components or edges or paths or layers else 0)
