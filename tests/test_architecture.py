"""The package's shape: no import circles, planning's rooms in the order of the data flow, short
functions. Imports are read from the source (every ``import`` statement, including those inside
functions and under ``TYPE_CHECKING``: a circle a type checker sees is still a circle)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: planning's rooms from the bottom up: a room imports only rooms before it (the top-level
#: modules ``solve``, ``rounds``, ``planner`` and ``bounds`` count as rooms of their own).
ROOMS = ["terms", "tasks", "methods", "nlp", "verdict", "search", "scene", "solve", "rounds", "planner", "online",
         "bounds"]
#: The longest chain of imports inside one room (nlp with its solvers: 7; planning/ as one
#: folder had 15).
MAX_ROOM_FLOORS = 7
MAX_FUNCTION_LINES = 80


def modules() -> dict[str, Path]:
    """Dotted name -> file of every module of the package (a package is its ``__init__``)."""
    out = {}
    for path in (SRC / "forte").rglob("*.py"):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def imports(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports (``from a import b``: ``a.b`` when it is a
    module, else ``a``). Importing a module also runs its packages' ``__init__``; those edges
    are left out, as every module would otherwise import its own package."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        for target in targets:
            while target not in known and "." in target:
                target = target.rpartition(".")[0]
            if target in known and target != name:
                found.add(target)
    return found


def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: imports(name, path, known) for name, path in known.items()}


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
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
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def floors(edges: dict[str, set[str]], members: set[str]) -> int:
    """The longest chain of imports among ``members`` (in modules: 1 when none imports another)."""
    memo: dict[str, int] = {}

    def height(v: str) -> int:
        if v not in memo:
            memo[v] = 1 + max((height(w) for w in edges[v] & members), default=0)
        return memo[v]

    return max(height(v) for v in members)


def room_of(name: str) -> str | None:
    parts = name.split(".")
    return parts[2] if len(parts) > 2 and parts[1] == "planning" else None


def test_the_circle_finder_finds_circles():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(edges) == [["a", "b", "c"]]
    assert floors({"a": {"b"}, "b": {"c"}, "c": set()}, {"a", "b", "c"}) == 3


def test_relative_and_aliased_imports_are_edges(tmp_path):
    known = {"forte.x": tmp_path / "x.py", "forte.x.y": tmp_path / "y.py", "forte.z": tmp_path / "z.py"}
    (tmp_path / "y.py").write_text("from . import z\nfrom ..x import y as w\nimport forte.z.missing\n")
    assert imports("forte.x.y", tmp_path / "y.py", known) == {"forte.x", "forte.z"}


def test_no_module_imports_another_that_imports_it_back():
    found = circles(graph())
    assert not found, "import circles: " + "; ".join(" <-> ".join(c) for c in found)


def test_planning_rooms_import_only_the_rooms_below():
    edges = graph()
    wrong = []
    for name, targets in edges.items():
        room = room_of(name)
        if room is None:
            continue
        assert room in ROOMS, f"{name}: planning/{room} is not a room of tests/test_architecture.ROOMS"
        for target in targets:
            other = room_of(target)
            if other is not None and ROOMS.index(other) > ROOMS.index(room):
                wrong.append(f"{name} -> {target}")
    assert not wrong, "imports against the flow: " + ", ".join(wrong)


@pytest.mark.parametrize("room", [r for r in ROOMS if r not in ("solve", "rounds", "planner", "bounds")])
def test_each_room_is_a_few_floors(room):
    edges = graph()
    members = {m for m in edges if room_of(m) == room}
    assert members
    assert floors(edges, members) <= MAX_ROOM_FLOORS


def test_no_function_is_longer_than_a_screen():
    long = []
    for path in (SRC / "forte").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(SRC)}:{node.name} ({lines} lines)")
    assert not long, "functions over 80 lines: " + ", ".join(long)
