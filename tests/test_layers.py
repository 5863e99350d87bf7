"""The package's layers point one way (docs/architecture.md, "Layers").

Every module under ``sarjax/`` is parsed (not imported) and each of its imports, at module
level or inside a function, becomes an edge of the module graph. The graph must have no
cycle, and no module may import from a layer above its own.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "sarjax"

# Module-name prefix -> layer; the longest matching prefix (on whole name components)
# wins. A module may import only from its own layer or the layers below. Every module
# must match an entry: a new module is placed here when it is added.
LAYERS = {
    # 0: core. Objects, physics and numerics shared by everything.
    "sarjax.constants": 0,
    "sarjax.antenna": 0,
    "sarjax.radar": 0,
    "sarjax.scene": 0,
    "sarjax.motion": 0,
    "sarjax.geometry": 0,
    "sarjax.presets": 0,
    "sarjax._numerics": 0,
    "sarjax._data": 0,
    "sarjax._files": 0,
    "sarjax._compilation_cache": 0,
    "sarjax._allocator": 0,
    "sarjax._exported": 0,
    "sarjax._names": 0,
    # 1: the simulators (a registry module under simulators/ that belongs to the
    # simulate layer gets its own entry with layer 2: the longest prefix wins).
    "sarjax.simulators": 1,
    # 2: the simulate layer: choosing, validating and running a simulator.
    "sarjax._simulate": 2,
    "sarjax._memory": 2,
    "sarjax._memory_plan": 2,
    "sarjax._sharding": 2,
    "sarjax.distributed": 2,
    "sarjax._validate": 2,
    "sarjax.validity": 2,
    # 3: focusing.
    "sarjax.processing": 3,
    # 4: image-quality metrics and their analytic expectations.
    "sarjax.metrics": 4,
    "sarjax.reference": 4,
    # 5: motion estimation and bounds.
    "sarjax.inverse": 5,
    # 6: figures.
    "sarjax.plot": 6,
    # 7: files: native NetCDF and the NGA standard exports.
    "sarjax.io": 7,
    "sarjax.export": 7,
    # 8: applications.
    "sarjax.demo": 8,
    "sarjax.campaign": 8,
    "sarjax.cli": 8,
}
# The package's own __init__ (the public namespace) sits above everything: no module
# of the package imports it. Only the exact name: it is not a prefix for the others.
ROOT_LAYER = 9

# Upward imports that exist today and are being removed, as (importer, imported). The
# test fails when a new one appears and when one listed here has gone (then delete its
# line), so the set only shrinks.
KNOWN_UPWARD: set[tuple[str, str]] = set()

# Imports that close a cycle today and are being removed, as (importer, imported); the
# same rule: a new cycle fails, and so does an entry that no longer closes one.
KNOWN_CYCLE_EDGES = {
    # cli.commands takes simulate_config from its package (__init__ imports commands)
    # so that it can be replaced there.
    ("sarjax.cli.commands", "sarjax.cli"),
}


# ---- the module graph ------------------------------------------------------------------


def _modules() -> dict[str, tuple[Path, bool]]:
    """Module name -> (file, is a package)."""
    out = {}
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts.pop()
        out[".".join(parts)] = (path, is_package)
    return out


MODULES = _modules()


def _existing(name: str) -> str | None:
    """``name`` or its longest prefix that is a module of the package."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in MODULES:
            return candidate
        parts.pop()
    return None


def _targets(module: str, node: ast.AST) -> list[str]:
    """The package modules one import statement of ``module`` imports."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        package = module if MODULES[module][1] else module.rpartition(".")[0]
        for _ in range(node.level - 1):
            package = package.rpartition(".")[0]
        base = f"{package}.{node.module}" if node.module else package
    else:
        base = node.module or ""
    # ``from pkg import name``: the submodule pkg.name where there is one, else pkg.
    return [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
            for alias in node.names]


def _edges(module: str, source: str) -> set[str]:
    """The package modules that ``module`` (with this source) imports."""
    edges = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            for target in _targets(module, node):
                if target == PACKAGE or target.startswith(PACKAGE + "."):
                    resolved = _existing(target)
                    assert resolved is not None, f"{module} imports unknown {target}"
                    edges.add(resolved)
    edges.discard(module)
    return edges


def _graph() -> dict[str, set[str]]:
    return {module: _edges(module, path.read_text()) for module, (path, _) in MODULES.items()}


GRAPH = _graph()


def layer(module: str) -> int:
    if module == PACKAGE:
        return ROOT_LAYER
    matches = [prefix for prefix in LAYERS
               if module == prefix or module.startswith(prefix + ".")]
    if not matches:
        raise KeyError(module)
    return LAYERS[max(matches, key=len)]


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle as a path [a, b, ..., a], or None (iterative depth-first search)."""
    state = dict.fromkeys(graph, 0)  # 0 unseen, 1 on the current path, 2 done
    for start in sorted(graph):
        if state[start]:
            continue
        path, stack = [start], [iter(sorted(graph[start]))]
        state[start] = 1
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[path.pop()] = 2
                stack.pop()
            elif state[nxt] == 1:
                return path[path.index(nxt):] + [nxt]
            elif state[nxt] == 0:
                state[nxt] = 1
                path.append(nxt)
                stack.append(iter(sorted(graph[nxt])))
    return None


# ---- the tests ----------------------------------------------------------------------------


def test_the_graph_sees_every_kind_of_import():
    source = textwrap.dedent("""
        import numpy
        import sarjax.io
        from .. import geometry
        from .. import simulate
        from ..simulators import TimeDomain
        from . import _omega_k
        from ._omega_k import omega_k

        def f():
            from .._numerics.interpolation import next_fast_len
            from sarjax.constants import SPEED_OF_LIGHT
    """)
    assert _edges("sarjax.processing._focus", source) == {
        "sarjax.io", "sarjax.geometry", "sarjax", "sarjax.simulators",
        "sarjax.processing._omega_k", "sarjax._numerics.interpolation", "sarjax.constants"}
    assert _edges("sarjax.processing", "from . import _focus\nfrom ._focus import focus") == {
        "sarjax.processing._focus"}


def test_no_import_cycle():
    # A package's __init__ importing its own submodules (how it re-exports them) closes a
    # cycle only where one of them imports the package back, and that is a cycle at run
    # time too: so every edge stays in the graph.
    graph = {module: targets - {b for a, b in KNOWN_CYCLE_EDGES if a == module}
             for module, targets in GRAPH.items()}
    cycle = _find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)
    for a, b in sorted(KNOWN_CYCLE_EDGES):
        back = {m: set(t) for m, t in graph.items()}
        back[a] = back.get(a, set()) | ({b} if b in GRAPH.get(a, ()) else set())
        assert _find_cycle(back) is not None, (
            f"{a} -> {b} no longer closes a cycle: remove it from KNOWN_CYCLE_EDGES")


def test_every_module_has_a_layer():
    missing = []
    for module in MODULES:
        try:
            layer(module)
        except KeyError:
            missing.append(module)
    assert not missing, f"modules without a layer in LAYERS: {missing}"
    unused = [prefix for prefix in LAYERS
              if not any(m == prefix or m.startswith(prefix + ".") for m in MODULES)]
    assert not unused, f"LAYERS entries that match no module: {unused}"


def test_no_module_imports_from_a_higher_layer():
    upward = {(module, target) for module, targets in GRAPH.items() for target in targets
              if layer(target) > layer(module)}
    new = sorted(upward - KNOWN_UPWARD)
    gone = sorted(KNOWN_UPWARD - upward)
    message = [f"{a} -> {b} (layer {layer(a)} -> {layer(b)})" for a, b in new]
    message += [f"{a} -> {b} no longer occurs: remove it from KNOWN_UPWARD" for a, b in gone]
    assert not message, "upward imports:\n" + "\n".join(message)


@pytest.mark.parametrize("module", ["sarjax", "sarjax.io", "sarjax.export", "sarjax.cli"])
def test_fresh_import_meets_no_partly_initialised_module(module):
    """Importing in a fresh interpreter never reaches a package module that is still
    being initialised (what an import cycle does at run time)."""
    script = textwrap.dedent(f"""
        import builtins, importlib, importlib.util, sys

        original = builtins.__import__
        seen = []

        def initialising(name):
            spec = getattr(sys.modules.get(name), "__spec__", None)
            return name.split(".")[0] == "sarjax" and getattr(spec, "_initializing", False)

        def hook(name, globals=None, locals=None, fromlist=(), level=0):
            importer = (globals or {{}}).get("__name__", "")
            result_name = name
            if level:
                name = importlib.util.resolve_name("." * level + name,
                                                   (globals or {{}}).get("__package__"))
            items = [f"{{name}}.{{item}}" for item in fromlist or () if item != "*"]
            busy = {{t for t in [name, *items] if initialising(t)}}
            result = original(result_name, globals, locals, fromlist, level)
            # The module itself, unless the importer is it or lies inside it (a package
            # is initialising while its __init__ and its submodules run) ...
            if name in busy and not (importer + ".").startswith(name + "."):
                seen.append(f"{{importer}} -> {{name}}")
            # ... a name taken from a package that is still initialising (an attribute
            # that may not exist yet, not a submodule) ...
            for item in items:
                if initialising(name) and item not in sys.modules:
                    seen.append(f"{{importer}} -> {{item}} (attribute of a package "
                                "being initialised)")
                # ... or a submodule that is itself being initialised.
                elif item in busy:
                    seen.append(f"{{importer}} -> {{item}}")
            return result

        builtins.__import__ = hook
        importlib.import_module({module!r})
        builtins.__import__ = original
        loaded = [m for n, m in sys.modules.items() if n.split(".")[0] == "sarjax"]
        assert loaded and all(m.__spec__ is not None for m in loaded)
        assert not [m for m in loaded if getattr(m.__spec__, "_initializing", False)]
        assert not seen, seen
    """)
    result = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
