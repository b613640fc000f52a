"""The house's structure: layers run one way and no import circle, function-level imports
included (STYLE.md points 19-20); the size limits DESIGN.md states."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "src" / "mbinspect"

#: Each module's layer, by the first rule its dotted name (without ``mbinspect.``) matches:
#: a name, or a package and everything in it. A module may import only its own layer and
#: those below.
LAYERS: tuple[tuple[int, tuple[str, ...]], ...] = (
    (0, ("errors", "version", "checks", "outputs", "options", "grid", "strays", "geometry", "cloud",
         "interrupt", "pages", "timing", "neighbours", "cellsort", "solids", "forked")),
    (1, ("crs", "formats", "sonar", "io", "describe", "fit", "reef_designs", "evaluate", "noise",
         "pipeline", "beam", "pings", "datum", "design_solids")),
    (2, ("seabed", "filters", "segment", "least_depth", "scour")),
    (3, ("piles", "reefs", "simulate", "report")),
    (4, ("pipelines", "inject", "results", "change", "plan")),
    (5, ("survey",)),
    (6, ("cli", "command", "")),
)

#: Packages of one layer that stand side by side and never import one another.
PEERS = ("piles", "reefs", "simulate", "report")


def _name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_name(p): p for p in ROOT.rglob("*.py")}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Every module of ours ``name`` imports, at module level or inside a function."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)] if node.level > 1 else package
                target = ".".join(base + ([node.module] if node.module else []))
            elif (node.module or "").startswith("mbinspect"):
                target = (node.module or "").removeprefix("mbinspect").lstrip(".")
            else:
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}".lstrip(".")
                out.add(sub if sub in known else target)
        elif isinstance(node, ast.Import):
            out |= {a.name.removeprefix("mbinspect").lstrip(".") for a in node.names
                    if a.name.startswith("mbinspect")}
    return {m for m in out if m in known and m != name}


def _layer(name: str) -> int:
    for layer, names in LAYERS:
        for n in names:
            if n and (name == n or name.startswith(n + ".")):
                return layer
    return LAYERS[-1][0]


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    return {m: _imports(m, p, set(mods)) for m, p in mods.items()}


def test_every_module_has_a_layer():
    placed = [n for _, names in LAYERS for n in names if n]
    unplaced = [m for m in _modules() if m and not any(m == n or m.startswith(n + ".") for n in placed)]
    assert unplaced == []


def test_imports_never_run_up_a_layer():
    graph = _graph()
    up = [f"{m} (layer {_layer(m)}) imports {t} (layer {_layer(t)})"
          for m, targets in graph.items() for t in targets if _layer(t) > _layer(m)]
    assert up == []


def test_peer_pipelines_do_not_import_one_another():
    graph = _graph()
    top = {m: m.split(".")[0] for m in graph}
    crossed = [f"{m} imports {t}" for m, targets in graph.items() for t in targets
               if top[m] in PEERS and top[t] in PEERS and top[m] != top[t]]
    assert crossed == []


def test_no_import_circle():
    graph = _graph()
    # a package's __init__ gathering its own modules is not a circle: leave those edges out
    edges = {m: {t for t in ts if not (m and t.startswith(m + "."))} for m, ts in graph.items()}
    state: dict[str, int] = {}
    circles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for t in sorted(edges[m]):
            if state.get(t) == 1:
                circles.append(path[path.index(t):] + [t] if t in path else [m, t])
            elif t not in state:
                visit(t, path + [t])
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m, [m])
    assert circles == []


def test_the_checker_sees_a_circle_and_an_import_up_a_layer(tmp_path):
    """The walk reads function-level imports and relative ones."""
    path = tmp_path / "mod.py"
    path.write_text("def f():\n    from ..survey import run\n    from .cloud import PointCloud\n")
    found = _imports("piles.mod", path, {"survey", "survey.run", "piles.cloud"})
    assert found == {"survey.run", "piles.cloud"}
    assert _layer("survey.run") > _layer("piles.mod")


@pytest.mark.parametrize("limit_lines, limit_body", [(400, 60)])
def test_modules_and_functions_stay_small(limit_lines, limit_body):
    """No module over 400 lines, no function body over 60 lines (docstring excluded), as
    ``tools/code_metrics.py`` counts them."""
    big, long = [], []
    for path in ROOT.rglob("*.py"):
        text = path.read_text()
        if len(text.splitlines()) > limit_lines:
            big.append(f"{_name(path)}: {len(text.splitlines())} lines")
        tree = ast.parse(text)
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                first = node.body[0]
                doc = isinstance(first, ast.Expr) and isinstance(getattr(first, "value", None), ast.Constant)
                skip = (first.end_lineno - first.lineno + 1) if doc else 0
                body = node.end_lineno - node.lineno + 1 - skip
                if body > limit_body:
                    long.append(f"{_name(path)}:{node.name}: {body} lines")
    assert big == [] and long == []
