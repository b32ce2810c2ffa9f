"""The shape of the code the stages issue (28) left, kept: no function over 100 lines, none with
more than 8 parameters (numba kernels aside), no private name imported from another module and
no import cycle, module-level or through function-local imports (docs/architecture.md).

An AST scan of ``src/elastic_motion``; a failure names the functions or modules."""

from __future__ import annotations

import ast
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "elastic_motion"
MAX_LINES = 100
MAX_PARAMS = 8


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name (a package by its ``__init__``)."""
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = modules()
TREES = {name: ast.parse(path.read_text(encoding="utf-8")) for name, path in MODULES.items()}


def functions() -> Iterator[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]]:
    for name, tree in TREES.items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield f"{name}.{node.name}", node


def imported_module(module: str, node: ast.ImportFrom) -> str:
    """The absolute module an ``import from`` names (relative imports resolved)."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if MODULES[module].name != "__init__.py":
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports(module: str, tree: ast.Module) -> Iterator[tuple[str, str]]:
    """``(module imported, name)`` of every runtime import in ``tree`` (module level and inside
    functions; ``if TYPE_CHECKING:`` blocks skipped); ``name`` is ``""`` for ``import x``."""
    skipped = {id(n) for s in tree.body if isinstance(s, ast.If) for n in ast.walk(s)}
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.ImportFrom):
            target = imported_module(module, node)
            for alias in node.names:
                yield target, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, ""


def test_no_function_is_over_100_lines():
    long = [f"{name} ({node.end_lineno - node.lineno + 1})" for name, node in functions()
            if node.end_lineno - node.lineno + 1 > MAX_LINES]  # fmt: skip
    assert not long, f"functions over {MAX_LINES} lines: {long}"


def test_no_function_takes_more_than_8_parameters():
    many = []
    for name, node in functions():
        args = node.args
        params = [
            a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs) if a.arg not in ("self", "cls")
        ]
        params += [a.arg for a in (args.vararg, args.kwarg) if a is not None]
        jitted = any("jit" in ast.unparse(d) for d in node.decorator_list)  # numba kernels
        if len(params) > MAX_PARAMS and not jitted:
            many.append(f"{name} ({len(params)})")
    assert not many, f"functions with more than {MAX_PARAMS} parameters: {many}"


def test_no_private_name_is_imported_from_another_module():
    private = [
        f"{module} <- {target}.{name}"
        for module, tree in TREES.items()
        for target, name in imports(module, tree)
        if target.startswith("elastic_motion") and name.startswith("_") and not name.startswith("__")
    ]
    assert not private, f"private names imported across modules: {private}"


def import_graph() -> dict[str, set[str]]:
    """Which of the package's modules each module imports (a name that is a submodule counts
    as that submodule)."""
    graph: dict[str, set[str]] = defaultdict(set)
    for module, tree in TREES.items():
        for target, name in imports(module, tree):
            if not target.startswith("elastic_motion"):
                continue
            sub = f"{target}.{name}"
            dep = sub if sub in MODULES else target
            if dep != module and dep in MODULES:
                graph[module].add(dep)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in MODULES:
        if start in index:
            continue
        work = [(start, iter(sorted(graph.get(start, ()))))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
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


def test_no_import_cycles():
    assert not cycles(import_graph())


@pytest.mark.parametrize(
    ("graph", "expected"),
    [
        ({"a": {"b"}, "b": {"a"}}, [["a", "b"]]),
        ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
        ({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}, [["a", "b", "c"]]),
    ],
)
def test_the_cycle_finder_finds_cycles(graph, expected, monkeypatch):
    monkeypatch.setitem(globals(), "MODULES", dict.fromkeys(["a", "b", "c", "d"]))
    assert cycles(graph) == expected
