"""Size and shape of the code: lines per module, the longest functions, their branching,
and the public functions without a numpydoc ``Parameters`` section or an example.

Run: ``python tools/code_metrics.py [src/mbinspect]`` (or a subfolder such as
``src/mbinspect/piles``). Cyclomatic complexity is counted as
1 + the branch points (if, for, while, except, with, boolean operators, comprehension
conditions, ternaries, match cases), as radon and mccabe count it.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def complexity(fn: ast.AST) -> int:
    n = 1
    for node in ast.walk(fn):
        if isinstance(node, (ast.If, ast.For, ast.While, ast.AsyncFor, ast.ExceptHandler, ast.IfExp,
                             ast.With, ast.AsyncWith, ast.match_case)):
            n += 1
        elif isinstance(node, ast.BoolOp):
            n += len(node.values) - 1
        elif isinstance(node, ast.comprehension):
            n += 1 + len(node.ifs)
    return n


def code_lines(fn: ast.FunctionDef) -> int:
    """Lines of a function without its docstring."""
    first = fn.body[0]
    doc = isinstance(first, ast.Expr) and isinstance(getattr(first, "value", None), ast.Constant)
    skip = (first.end_lineno - first.lineno + 1) if doc else 0
    return fn.end_lineno - fn.lineno + 1 - skip


def functions(tree: ast.Module) -> list[tuple[str, ast.FunctionDef]]:
    out = []
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out.append((node.name, node))
        elif isinstance(node, ast.ClassDef):
            out += [(f"{node.name}.{m.name}", m) for m in node.body if isinstance(m, ast.FunctionDef)]
    return out


def main(root: str = "src/mbinspect") -> None:
    base = Path(root)
    rows, funcs, undocumented, no_example, public = [], [], [], [], 0
    for path in sorted(base.rglob("*.py")):
        rel = path.relative_to(base.parent)
        text = path.read_text()
        rows.append((str(rel), len(text.splitlines())))
        tree = ast.parse(text)
        exported = None
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__" for t in node.targets):
                exported = set(ast.literal_eval(node.value))
        for name, fn in functions(tree):
            funcs.append((code_lines(fn), fn.end_lineno - fn.lineno + 1, complexity(fn), f"{rel}:{name}"))
            top = name.split(".")[0]
            if "." in name or name.startswith("_") or (exported is not None and top not in exported):
                continue
            public += 1
            doc = ast.get_docstring(fn) or ""
            if "Parameters\n" not in doc and fn.args.args + fn.args.kwonlyargs:
                undocumented.append(f"{rel}:{name}")
            if ">>>" not in doc:
                no_example.append(f"{rel}:{name}")
    print("| module | lines |\n|---|---|")
    for name, n in rows:
        print(f"| {name} | {n} |")
    print(f"\n{len(rows)} modules, {sum(n for _, n in rows)} lines; largest: "
          f"{max(rows, key=lambda r: r[1])}")
    print("\nlongest functions (code lines without the docstring, all lines, complexity):")
    for code, length, cc, name in sorted(funcs, reverse=True)[:8]:
        print(f"  {code:4d} {length:4d} {cc:4d}  {name}")
    print("most complex functions (complexity, code lines):")
    for code, _length, cc, name in sorted(funcs, key=lambda f: -f[2])[:6]:
        print(f"  {cc:4d} {code:4d}  {name}")
    print(f"\npublic functions: {public}; with a Parameters section (or no parameters): "
          f"{public - len(undocumented)}; with an example: {public - len(no_example)}")
    for name in undocumented:
        print(f"  no Parameters: {name}")


if __name__ == "__main__":
    main(*sys.argv[1:])
