"""Compiled functions call compiled functions with typed values, never with literals.

Numba types a literal int or bool passed from compiled code (``f(x, 0)``, ``f(x, True)``,
or a local ``n = 0`` passed on unchanged) as ``Literal[int](0)``, and compiles the callee
again for that value: one more copy of the callee, and of everything it calls with that
argument, on every first run. ``np.int64(0)`` and ``np.bool_(True)`` are typed values
and reuse the one copy. Before this rule, a first ``adavar demo`` compiled 27 such extra
copies (``_fill`` three times, ``_raw_dd`` eight times).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numba
import numpy as np

SRC = Path(__file__).resolve().parents[1] / "src"
_JIT_NAMES = {"jit", "njit", "threaded_jit"}


def _is_jit(node: ast.expr) -> bool:
    func = node.func if isinstance(node, ast.Call) else node
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    return name in _JIT_NAMES


def _modules() -> dict[str, ast.Module]:
    """The modules that can hold a compiled function (their text names ``jit``)."""
    out = {}
    for path in sorted((SRC / "adavar").rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if "jit" not in text:
            continue
        parts = path.relative_to(SRC).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = ast.parse(text)
    return out


def _compiled_functions(tree: ast.Module) -> tuple[set[str], list[ast.FunctionDef]]:
    """Names of the module's compiled functions, and the compiled function definitions."""
    names, defs = set(), []
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(map(_is_jit, node.decorator_list)):
            names.add(node.name)
            defs.append(node)
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            if _is_jit(node.value):  # name = jit(function)
                names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return names, defs


def _is_literal(node: ast.expr) -> bool:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd, ast.Not)):
        return _is_literal(node.operand)
    return isinstance(node, ast.Constant) and isinstance(node.value, (bool, int))


def _bound_names(target: ast.expr) -> list[str]:
    """The local names an assignment target binds (not subscripts or attributes)."""
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, (ast.Tuple, ast.List)):
        return [name for item in target.elts for name in _bound_names(item)]
    return []


def _literal_locals(function: ast.FunctionDef) -> set[str]:
    """Locals that some assignment in ``function`` sets to a literal int or bool."""
    out = set()
    for node in ast.walk(function):
        if isinstance(node, ast.Assign):
            values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
            for target in node.targets:
                if isinstance(target, ast.Tuple) and len(target.elts) == len(values):
                    pairs = zip(target.elts, values, strict=True)
                else:
                    pairs = [(target, node.value)]
                for name_target, value in pairs:
                    if _is_literal(value):
                        out.update(_bound_names(name_target))
    return out


def literal_arguments() -> list[str]:
    modules = _modules()
    compiled = {name: _compiled_functions(tree) for name, tree in modules.items()}
    found = []
    for module, tree in modules.items():
        callees = {name: name for name in compiled[module][0]}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module in compiled:
                for alias in node.names:
                    if alias.name in compiled[node.module][0]:
                        callees[alias.asname or alias.name] = alias.name
        for function in compiled[module][1]:
            literal_locals = _literal_locals(function)
            for call in ast.walk(function):
                if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)):
                    continue
                if call.func.id not in callees:
                    continue
                values = [*call.args, *(k.value for k in call.keywords)]
                bad = [
                    ast.unparse(v)
                    for v in values
                    if _is_literal(v) or (isinstance(v, ast.Name) and v.id in literal_locals)
                ]
                if bad:
                    found.append(
                        f"{module}:{call.lineno} {function.name} calls {call.func.id} with "
                        f"{', '.join(bad)}"
                    )
    return found


def test_no_compiled_call_passes_a_literal():
    found = literal_arguments()
    assert found == [], (
        "pass np.int64(...) or np.bool_(...) (or start the local at one) so that the callee "
        "is not compiled again for the literal:\n" + "\n".join(found)
    )


def test_the_check_sees_what_it_guards_against(tmp_path):
    # the premise: a literal compiles a second copy, a typed value does not
    @numba.njit
    def callee(a, flag):  # pragma: no cover - compiled
        return a + 1 if flag else a

    @numba.njit
    def caller(a):  # pragma: no cover - compiled
        n = 0
        return callee(a, True) + callee(n, np.bool_(True)) + callee(a, np.bool_(False))

    caller(3)
    # three copies: (int64, Literal[bool](True)), (Literal[int](0), bool), (int64, bool)
    literal = [s for s in callee.signatures if any(isinstance(t, numba.types.Literal) for t in s)]
    assert len(callee.signatures) == 3 and len(literal) == 2

    # the checker flags both ways of passing a literal, and not the typed ones
    package = tmp_path / "probe.py"
    package.write_text(
        "import numpy as np\n"
        "@jit\ndef callee(a, b):\n    return a\n"
        "@jit\ndef caller(a, c):\n"
        "    n = 0\n    m = np.int64(0)\n    c[0] = 0\n"
        "    return callee(a, 0) + callee(n, a) + callee(m, np.bool_(True)) + callee(c, a)\n",
        encoding="utf-8",
    )
    tree = ast.parse(package.read_text(encoding="utf-8"))
    names, defs = _compiled_functions(tree)
    assert names == {"callee", "caller"}
    literal_locals = _literal_locals(defs[1])
    assert literal_locals == {"n"}
    calls = [
        c
        for c in ast.walk(defs[1])
        if isinstance(c, ast.Call) and getattr(c.func, "id", "") == "callee"
    ]
    calls.sort(key=lambda c: c.col_offset)  # ast.walk goes breadth first
    flagged = [
        any(_is_literal(v) or (isinstance(v, ast.Name) and v.id in literal_locals) for v in c.args)
        for c in calls
    ]
    assert flagged == [True, True, False, False]
