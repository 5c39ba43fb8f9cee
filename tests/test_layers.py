"""The house's architecture, checked from the code's own imports.

Layers, lowest first: ``planner`` (the library, NumPy/SciPy only) < ``sim`` (simulators) <
``scenarios`` (registered examples) < ``qsplan`` (the application: command line and report).
A module may import its own layer and the layers below it, never a higher one; no import
circles (lazy imports inside functions count); no private name (``_x``) imported from another
module; no module much over 400 lines.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("planner", "sim", "scenarios", "qsplan")
#: "No module over about 400 lines" (the project's rule); the hard stop leaves room for a docstring.
MAX_LINES = 450


def _modules() -> dict[str, Path]:
    out = {}
    for top in LAYERS:
        for p in sorted((ROOT / top).rglob("*.py")):
            rel = p.relative_to(ROOT).with_suffix("")
            parts = list(rel.parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = p
    return out


MODULES = _modules()


def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """(module imported, names taken from it, line) for every import in the file, lazy included."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((a.name, [], node.lineno) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.append((node.module, [a.name for a in node.names], node.lineno))
    return out


def _resolve(name: str) -> str | None:
    """The project module an import names (longest known prefix), or None if external."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        cand = ".".join(parts[:k])
        if cand in MODULES:
            return cand
    return None


def _graph() -> dict[str, set[str]]:
    g: dict[str, set[str]] = {m: set() for m in MODULES}
    for mod, path in MODULES.items():
        for name, names, _ in _imports(path):
            target = _resolve(name)
            if target is None:
                continue
            # ``from pkg import sub`` names a submodule: follow it too.
            for n in names:
                sub = _resolve(f"{name}.{n}")
                if sub is not None and sub != target:
                    g[mod].add(sub)
            if not (names and all(_resolve(f"{name}.{n}") not in (None, target) for n in names)):
                g[mod].add(target)
            g[mod].discard(mod)
    return g


def test_the_walk_sees_every_layer():
    """Guard against a walk that finds nothing (and so can never fail)."""
    tops = {m.split(".")[0] for m in MODULES}
    assert tops == set(LAYERS)
    edges = sum(len(v) for v in _graph().values())
    assert edges > 100, edges


def test_lower_layers_never_import_higher_ones():
    bad = []
    for mod, path in MODULES.items():
        rank = LAYERS.index(mod.split(".")[0])
        for name, _, line in _imports(path):
            top = name.split(".")[0]
            if top in LAYERS and LAYERS.index(top) > rank:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {name}")
    assert not bad, "\n".join(bad)


def _find_cycle(g: dict[str, set[str]]) -> list[str] | None:
    colour: dict[str, int] = {}
    stack: list[str] = []

    def visit(u: str) -> list[str] | None:
        colour[u] = 1
        stack.append(u)
        for v in sorted(g[u]):
            if colour.get(v) == 1:
                return stack[stack.index(v):] + [v]
            if v not in colour:
                found = visit(v)
                if found:
                    return found
        stack.pop()
        colour[u] = 2
        return None

    for u in sorted(g):
        if u not in colour:
            found = visit(u)
            if found:
                return found
    return None


def test_no_import_circles():
    # Package faces (``__init__``) re-export their submodules; an edge from a submodule to its
    # own package face would be a circle only through that face, so faces that merely hand
    # names on are left out of the graph, as farm-studio does.
    g = _graph()
    faces = {m for m, p in MODULES.items() if p.name == "__init__.py"}
    h = {u: {v for v in vs if v not in faces} for u, vs in g.items() if u not in faces}
    cycle = _find_cycle(h)
    assert cycle is None, " -> ".join(cycle or [])


def test_cycle_finder_finds_a_planted_circle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_private_name_is_imported_from_another_module():
    bad = []
    for path in MODULES.values():
        for name, names, line in _imports(path):
            if _resolve(name) is None:
                continue
            for n in names:
                if n.startswith("_") and not n.startswith("__"):
                    bad.append(f"{path.relative_to(ROOT)}:{line} imports {name}.{n}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("mod", sorted(MODULES))
def test_module_size(mod):
    n = len(MODULES[mod].read_text().splitlines())
    assert n <= MAX_LINES, f"{MODULES[mod].relative_to(ROOT)}: {n} lines (limit {MAX_LINES})"


@pytest.mark.long
def test_the_library_imports_no_simulator_or_plotting_library():
    """``import planner`` and every planner subpackage load without matplotlib, pymunk, mujoco."""
    subs = sorted({m for m in MODULES if m.startswith("planner")})
    code = (
        "import importlib, sys\n"
        f"for m in {subs!r}: importlib.import_module(m)\n"
        "bad = [m for m in ('matplotlib', 'pymunk', 'mujoco', 'sim', 'scenarios', 'qsplan') "
        "if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "", f"planner imported {res.stdout.strip()} at module import"
