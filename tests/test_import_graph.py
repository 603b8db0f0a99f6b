"""The package's import graph (docs/architecture.md): no import cycle, counting imports inside functions, and no
module longer than a sitting's read.

import-linter holds the layers between packages; inside a package two modules could still import each other, one
of them from inside a function where no import-time error shows it.  This test reads every import statement of
every module (at any depth) and fails on any strongly connected group of modules.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import berryshaker

SRC = Path(berryshaker.__file__).parent
#: the longest module (lines) the layout allows (issue 46: "no module over 700 lines")
MAX_MODULE_LINES = 700


def _module_name(path: Path, src: Path) -> str:
    parts = path.relative_to(src.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(src: Path = SRC) -> dict[str, set[str]]:
    """Module -> the package modules it imports (``import a.b``, ``from a import b``, ``from . import b``;
    a name imported from a package counts as its module when one of that name exists), at any depth."""
    paths = {_module_name(p, src): p for p in src.rglob("*.py")}
    graph: dict[str, set[str]] = defaultdict(set)
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - node.level + 1]
                    module = ".".join(base + ([node.module] if node.module else []))
                else:
                    module = node.module or ""
                # ``from pkg import sub`` imports the module pkg.sub, and runs pkg/__init__ first
                targets = [module] + [f"{module}.{a.name}" for a in node.names]
            else:
                continue
            graph[name].update(t for t in targets if t in paths and t != name)
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of two or more modules (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[v] = min(low[v], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                group = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    group.append(w)
                    if w == v:
                        break
                if len(group) > 1:
                    groups.append(sorted(group))
    return groups


def test_the_cycle_finder_finds_a_cycle_through_a_function_level_import(tmp_path):
    pkg = tmp_path / "berryshaker"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from berryshaker.sub import b\n")
    (pkg / "sub" / "a.py").write_text("def f():\n    from berryshaker.sub.b import g\n")
    (pkg / "sub" / "b.py").write_text("from . import a\n")
    (pkg / "c.py").write_text("import berryshaker.sub.a\n")
    cycles = import_cycles(import_graph(pkg))
    assert cycles == [["berryshaker.sub", "berryshaker.sub.a", "berryshaker.sub.b"]]  # b imports the package: its __init__


def test_no_import_cycle_even_inside_functions():
    graph = import_graph()
    cycles = import_cycles(graph)
    detail = ["  " + " <-> ".join(c) + ": " + "; ".join(f"{a} -> {b}" for a in c for b in sorted(graph[a] & set(c)))
              for c in cycles]
    assert not cycles, "modules that import each other (directly or round a loop):\n" + "\n".join(detail)


def test_no_module_over_the_limit():
    long = sorted(f"{p.relative_to(SRC)} ({p.read_text('utf-8').count(chr(10))} lines)" for p in SRC.rglob("*.py")
                  if p.read_text("utf-8").count("\n") > MAX_MODULE_LINES)
    assert not long, f"modules over {MAX_MODULE_LINES} lines (split by idea, docs/architecture.md): " + ", ".join(long)


def test_no_private_name_is_imported_from_another_package():
    """A name with a leading underscore is shared at most inside its package (siblings of a re-cut module);
    another package imports only public, documented names."""
    found = []
    for path in SRC.rglob("*.py"):
        module = _module_name(path, SRC)
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").startswith("berryshaker"):
                source = node.module
                source_package = source.rpartition(".")[0] if (SRC.parent / (source.replace(".", "/") + ".py")).exists() \
                    else source
                # a top-level module (berryshaker.quantity_fields) is a package of its own here
                related = source_package == package or (source_package != "berryshaker" and package != "berryshaker" and (
                    source_package.startswith(package + ".") or package.startswith(source_package + ".")))
                if not related:
                    found += [f"{module}: from {node.module} import {a.name}" for a in node.names
                              if a.name.startswith("_") and not a.name.startswith("__")]
    assert not found, "private names imported from another package:\n  " + "\n  ".join(sorted(found))


def test_no_function_or_class_takes_the_name_of_a_module_of_its_package():
    """``pkg.name`` is one thing: a function re-exported under the name of a sibling module hides that module from
    ``pkg.name`` and gives the API reference two pages for one name (Sphinx: duplicate object description)."""
    import importlib
    import inspect
    import pkgutil

    clashes = []
    for info in pkgutil.walk_packages(berryshaker.__path__, "berryshaker."):
        if not info.ispkg:
            continue
        package = importlib.import_module(info.name)
        for sub in pkgutil.iter_modules(package.__path__):
            obj = getattr(package, sub.name, None)
            if inspect.isfunction(getattr(obj, "py_func", obj)) or inspect.isclass(obj):
                clashes.append(f"{info.name}.{sub.name}")
    assert not clashes, "a function or class named like a module of its package: " + ", ".join(clashes)
