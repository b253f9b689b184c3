"""The package's import graph, read with ``ast`` from the source: a DAG, benchmarks above the library, no
private name taken from another module, and ``dir(manylights)`` holding only the public API."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import manylights as ml

PKG = Path(ml.__file__).resolve().parent
#: The subpackages and modules a user may reach as attributes of ``manylights``.
SUBMODULES = {"animation", "distributed", "io", "lights", "matrix", "metrics", "relight", "renderers", "scene",
              "scenes"}


def module_name(path: Path) -> str:
    parts = path.relative_to(PKG.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    """Every module of the package by name; the native extension by its stub."""
    return {module_name(p): p for p in [*PKG.rglob("*.py"), PKG / "_native.pyi"]}


def resolve(importer: str, is_package: bool, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = importer.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(mods: dict[str, Path]) -> dict[str, list[tuple[str, int, bool, list[str]]]]:
    """module -> [(imported module, line, inside a function, names taken)] for imports of this package."""
    out: dict[str, list] = {}
    for name, path in mods.items():
        tree = ast.parse(path.read_text(), str(path))
        in_function = set()
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                in_function.update(id(n) for n in ast.walk(fn) if n is not fn)
        edges = []
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name == "manylights" or a.name.startswith("manylights."):
                        edges.append((a.name, node.lineno, id(node) in in_function, []))
            elif isinstance(node, ast.ImportFrom):
                target = resolve(name, path.name == "__init__.py", node)
                if not (target == "manylights" or target.startswith("manylights.")):
                    continue
                names = [a.name for a in node.names]
                subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in mods]
                taken = [n for n in names if f"{target}.{n}" not in mods]
                for s in subs:
                    edges.append((s, node.lineno, id(node) in in_function, []))
                if taken or not subs:
                    edges.append((target, node.lineno, id(node) in in_function, taken))
        out[name] = edges
    return out


@pytest.fixture(scope="module")
def graph():
    mods = modules()
    return mods, imports(mods)


def test_no_cycle(graph):
    mods, edges = graph
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for target, line, _, _ in edges.get(m, []):
            if target not in mods:
                continue
            if state.get(target) == 1:
                cycle = stack[stack.index(target):] + [target]
                pytest.fail(f"import cycle: {' -> '.join(cycle)} ({mods[m].name}:{line})")
            if state.get(target) is None:
                visit(target)
        stack.pop()
        state[m] = 2

    for m in sorted(mods):
        if m not in state:
            visit(m)
    assert len(state) == len(mods) > 60


def test_library_never_imports_a_benchmark_or_the_command_line(graph):
    mods, edges = graph
    bad = [f"{m} imports {t} (line {line})" for m, es in edges.items() for t, line, _, _ in es
           if not m.startswith(("manylights.bench", "manylights.cli", "manylights.__main__"))
           and t.startswith(("manylights.bench", "manylights.cli"))]
    assert not bad, bad
    # The library is imported through its modules, never through the package face (which imports everything).
    face = [f"{m} imports manylights (line {line})" for m, es in edges.items() for t, line, _, _ in es
            if t == "manylights" and not m.startswith("manylights.bench")]
    assert not face, face


def test_no_package_import_inside_a_function(graph):
    mods, edges = graph
    inside = [f"{m} line {line}: {t}" for m, es in edges.items() for t, line, fn, _ in es
              if fn and not m.startswith("manylights.bench")]
    assert not inside, inside


def test_no_private_name_taken_from_another_module(graph):
    mods, edges = graph
    private = [f"{m} line {line}: {t}.{n}" for m, es in edges.items() for t, line, _, names in es for n in names
               if n.startswith("_") and n != "__version__"]
    assert not private, private


def test_dir_holds_only_the_public_api():
    """In a fresh interpreter (other tests import ``manylights.bench``, ``.cli`` and ``.testing``, which then show
    up as attributes too)."""
    import json
    import subprocess
    import sys

    code = "import json, manylights; print(json.dumps([n for n in dir(manylights) if not n.startswith('_')]))"
    public = set(json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                           check=True).stdout))
    assert public == set(ml.__all__) | SUBMODULES, sorted(public ^ (set(ml.__all__) | SUBMODULES))
    assert len(ml.__all__) == len(set(ml.__all__)) == 63
    for name in ml.__all__:
        assert getattr(ml, name) is not None, name
    for name in ("mrcs", "render", "LightMatrix", "load_scene", "generate_lights", "tensor_clustering",
                 "DirectToIndirect", "sweep", "write_exr"):
        assert callable(getattr(ml, name)), name


def test_optional_dependencies_load_lazily():
    import subprocess
    import sys

    code = ("import sys, manylights; heavy = [m for m in ('dask', 'distributed', 'pandas', 'pyarrow', 'matplotlib',"
            " 'mitsuba', 'imageio', 'sklearn') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", out
