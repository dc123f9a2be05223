"""The package's shape: imports flow one way, no circle, short functions.

Read from the source (module-level imports and imports inside functions alike), so a circle
hidden in a function is found too. The layers, lowest first: a module may import its own layer
or lower ones, never a higher one (docs/architecture.md draws the same order).
"""

import ast
import collections
import pathlib

SRC = pathlib.Path(__file__).resolve().parents[1] / "src" / "freeplayid"

LAYERS = [
    # ground floor
    ("errors", "arguments", "atomic", "quantity", "sweep", "acquisition", "dataset", "plots",
     "progress", "threads"),
    ("model",),
    ("io",),
    ("simulate",),
    ("signal",),
    ("backbone",),
    ("fit",),
    ("quality",),
    ("estimate",),
    ("replay",),
    ("identification",),
    ("inverse",),
    ("studies",),
    ("tasks",),
]
LEVEL = {name: i for i, names in enumerate(LAYERS) for name in names}
MAX_CODE_LINES = 100  # per function, docstring, blank and comment lines excluded


def _modules() -> dict[str, pathlib.Path]:
    out = {}
    for path in SRC.rglob("*.py"):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(mods: dict) -> dict[str, set]:
    edges = collections.defaultdict(set)
    for name, path in mods.items():
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = package[: len(package) - node.level + 1] if node.level else []
                target = ".".join(base + ([node.module] if node.module else []))
                if target.split(".")[0] != "freeplayid":
                    continue
                for alias in node.names:  # a name may be a submodule
                    sub = f"{target}.{alias.name}"
                    edges[name].add(sub if sub in mods else target)
            elif isinstance(node, ast.Import):
                edges[name] |= {a.name for a in node.names if a.name.startswith("freeplayid.")}
    return edges


def _layer(module: str) -> int | None:
    parts = module.split(".")
    return LEVEL.get(parts[1]) if len(parts) > 1 else None


def _cycles(mods: dict, edges: dict) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in mods:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in mods:
        if v not in index:
            visit(v)
    return out


def test_every_module_has_a_layer():
    missing = sorted({m.split(".")[1] for m in _modules() if "." in m and _layer(m) is None})
    assert not missing, f"modules in no layer: {missing} (add them to LAYERS and the docs)"


def test_no_import_runs_up_the_layers():
    mods = _modules()
    up = sorted((a, b) for a, targets in _imports(mods).items() for b in targets
                if _layer(a) is not None and _layer(b) is not None and _layer(b) > _layer(a))
    assert not up, "imports from a lower layer to a higher one:\n" + "\n".join(
        f"  {a} -> {b}" for a, b in up)


def test_no_import_circle():
    mods = _modules()
    cycles = _cycles(mods, _imports(mods))
    assert not cycles, "import circles:\n" + "\n".join("  " + " <-> ".join(c) for c in cycles)


def test_the_layer_check_finds_a_circle_and_an_upward_import():
    # the checks above are only as good as the reading of imports: a planted circle and an
    # upward import (relative, inside a function) must be seen
    mods = {"freeplayid.fit.a": SRC, "freeplayid.fit.b": SRC}
    assert _cycles(mods, {"freeplayid.fit.a": {"freeplayid.fit.b"},
                          "freeplayid.fit.b": {"freeplayid.fit.a"}}) == [list(mods)]
    tree = ast.parse("def f():\n    from ..replay import corrected_fit\n")
    node = next(n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom))
    assert node.level == 2 and _layer(f"freeplayid.{node.module}") > _layer("freeplayid.fit")


def _numba_kernel(node) -> bool:
    """A function compiled by numba (``@njit``, ``@numba.njit(...)``, ``@nb.jit``...)."""
    for d in node.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("njit", "jit", "vectorize", "guvectorize"):
            return True
    return False


def _code_lines(lines: list[str], node) -> int:
    skip = set()
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        skip = set(range(body[0].lineno, body[0].end_lineno + 1))
    return sum(1 for i in range(node.lineno, node.end_lineno + 1)
               if i not in skip and lines[i - 1].strip()
               and not lines[i - 1].strip().startswith("#"))


def test_no_function_over_100_lines_of_code():
    long = []
    for path in sorted(SRC.rglob("*.py")):
        text = path.read_text()
        lines = text.splitlines()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                    and not _numba_kernel(node):
                n = _code_lines(lines, node)
                if n > MAX_CODE_LINES:
                    long.append(f"  {path.relative_to(SRC)}:{node.name} ({n} lines)")
    assert not long, "functions over 100 lines of code:\n" + "\n".join(long)
