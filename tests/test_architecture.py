"""The rules of docs/architecture.md that a machine can check, on the source tree itself."""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "adavar"

#: attribute names that start with an underscore by a file format's convention, not
#: because they are a library's private attribute (a netCDF variable's CF attribute)
_FORMAT_NAMES = {"_FillValue"}


@cache
def _modules() -> dict[Path, ast.Module]:
    return {path: ast.parse(path.read_text(), str(path)) for path in sorted(SRC.rglob("*.py"))}


@cache
def _own_private_names() -> frozenset[str]:
    """Every ``_name`` adavar itself defines: functions, classes, assigned names and
    attributes, parameters."""
    names: set[str] = set()
    for tree in _modules().values():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                names.add(node.id)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                names.add(node.attr)
            elif isinstance(node, ast.arg):
                names.add(node.arg)
            elif isinstance(node, ast.alias):
                names.add(node.asname or node.name.split(".")[-1])
    return frozenset(n for n in names if n.startswith("_"))


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__") and name not in _FORMAT_NAMES


def test_no_private_attribute_of_another_library_is_used():
    """``x._name`` (or ``getattr(x, "_name")``) only for names adavar defines itself; no
    import of another package's private module or name."""
    own = _own_private_names()
    found = []
    for path, tree in _modules().items():
        where = path.relative_to(SRC.parent)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr) and node.attr not in own:
                found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
            elif (
                isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in ("getattr", "setattr", "hasattr") and len(node.args) >= 2
                and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)
                and _private(node.args[1].value) and node.args[1].value not in own
            ):  # fmt: skip
                found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                module = getattr(node, "module", None) or ""
                if getattr(node, "level", 0) or module.startswith("adavar"):
                    continue
                paths = [module] if module else []
                paths += [a.name if not module else f"{module}.{a.name}" for a in node.names]
                for dotted in paths:
                    if any(_private(part) for part in dotted.split(".")):
                        found.append(f"{where}:{node.lineno}: import of {dotted}")
    assert found == []


def _calls(tree: ast.Module, owner: str, names: set[str]) -> list[int]:
    return [
        node.lineno for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
        and isinstance(node.func.value, ast.Name) and node.func.value.id == owner
        and node.func.attr in names
    ]  # fmt: skip


_ENVIRONMENT_SETTERS = {"os.environ.setdefault", "os.environ.update", "os.putenv"}


def _runs_on_import(tree: ast.Module):
    """The nodes a module runs as it is imported (not the bodies of its functions)."""
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def test_no_process_wide_tricks():
    """No garbage-collector switches, no module class swapped, no environment variable set
    at import (the console script's own ``NUMBA_OPT`` is set in a function it calls)."""
    found = []
    for path, tree in _modules().items():
        where = path.relative_to(SRC.parent)
        for line in _calls(tree, "gc", {"freeze", "disable", "set_threshold"}):
            found.append(f"{where}:{line}: gc")
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and node.attr == "__class__"
                and isinstance(node.ctx, ast.Store)
            ):
                found.append(f"{where}:{node.lineno}: a module's class replaced")
        for sub in _runs_on_import(tree):
            if isinstance(sub, ast.Call) and ast.unparse(sub.func) in _ENVIRONMENT_SETTERS:
                found.append(f"{where}:{sub.lineno}: environment set on import")
            elif (
                isinstance(sub, ast.Subscript)
                and isinstance(sub.ctx, ast.Store)
                and (ast.unparse(sub.value) == "os.environ")
            ):
                found.append(f"{where}:{sub.lineno}: environment set on import")
    assert found == []


@pytest.mark.parametrize("limit", [1000])
def test_no_file_over_the_line_limit(limit):
    long = {
        str(path.relative_to(SRC.parent)): n
        for path in _modules()
        if (n := len(path.read_text().splitlines())) > limit
    }
    assert long == {}


def test_functions_keep_their_names_whatever_is_imported():
    """``adavar.davar`` and ``adavar.compare`` stay the functions after their modules are
    imported: the modules have other names, so no module's class has to be swapped."""
    import adavar
    import adavar.comparison
    import adavar.dynamic.surface

    assert adavar.davar is adavar.dynamic.surface.davar
    assert adavar.compare is adavar.comparison.compare
    from adavar import cli
    from adavar.cli import entry

    assert cli.main is entry.main and callable(cli.main)


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _public_module(dotted: str) -> bool:
    return not any(_private(part) for part in dotted.split("."))


def test_no_module_takes_another_public_modules_private_names():
    """A name another module needs is not private: ``from adavar.x import _y`` and
    ``x._y`` of a public module ``adavar.x`` are refused (private modules such as
    ``adavar._kernels`` or ``adavar._kernels._jit`` are internal as a whole)."""
    found = []
    for path, tree in _modules().items():
        here = _module_name(path)
        aliases: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("adavar"):
                for alias in node.names:
                    target = f"{node.module}.{alias.name}"
                    aliases[alias.asname or alias.name] = target
                    if (
                        _private(alias.name) and _public_module(node.module)
                        and node.module not in (here, "adavar")
                    ):  # fmt: skip
                        found.append(f"{here}: from {node.module} import {alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("adavar") and alias.asname:
                        aliases[alias.asname] = alias.name
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute) and _private(node.attr)
                and isinstance(node.value, ast.Name) and node.value.id in aliases
            ):  # fmt: skip
                target = aliases[node.value.id]
                if _public_module(target) and target != here:
                    found.append(f"{here}: {target}.{node.attr}")
    assert found == []


def _imports(path: Path, tree: ast.Module, modules: set[str]) -> set[str]:
    """The adavar modules ``path`` imports, inside functions too (not under
    ``if TYPE_CHECKING:``, which never runs)."""
    here = _module_name(path)
    skipped = {
        id(sub)
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for sub in ast.walk(node)
    }
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name in modules}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            subs = {f"{node.module}.{a.name}" for a in node.names} & modules
            if subs:
                found |= subs
            elif node.module in modules and not (
                node.module == "adavar" and all(a.name == "__version__" for a in node.names)
            ):
                found.add(node.module)
    return found - {here}


def test_no_import_cycles_even_inside_functions():
    """The modules form layers: no module reaches itself through imports, whether they
    run at import time or in a function (a function-level import is still a cycle)."""
    modules = {_module_name(path) for path in _modules()}
    graph = {_module_name(p): _imports(p, t, modules) for p, t in _modules().items()}
    cycles = []
    state: dict[str, int] = {}  # 1 on the path, 2 done

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycles.append([*path[path.index(nxt) :], nxt])
            elif nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for start in sorted(graph):
        if start not in state:
            visit(start, [start])
    assert cycles == []


#: The layers, lowest first: a module imports from its own layer and those below, never
#: from above (docs/architecture.md). ``name.*``: a package and everything in it.
LAYERS = [
    ("core", ["adavar.core.*"]),
    ("kernels", ["adavar._kernels.*"]),
    ("io", ["adavar.io.*", "adavar.readers.*"]),
    ("simulation", ["adavar.simulation.*"]),
    ("stats", ["adavar.stats.*"]),
    ("fit", ["adavar.fit.*"]),
    ("dynamic", ["adavar.dynamic.*"]),
    ("paper", ["adavar.paper.*", "adavar.comparison", "adavar.simulate"]),
    ("output", ["adavar.output.*"]),
    ("pipeline", ["adavar.pipeline.*"]),
    ("cli", ["adavar.cli.*"]),
    ("package", [
        "adavar", "adavar.adaptive", "adavar.analysis", "adavar.batch", "adavar.datasets",
        "adavar.demo", "adavar.events", "adavar.export", "adavar.long_tau", "adavar.plots",
        "adavar.precompile", "adavar.report", "adavar.report_parts", "adavar.settings",
        "adavar.stream", "adavar.surface", "adavar.surface_fit",
    ]),
]  # fmt: skip

#: Calls upward that run only when a user asks for them, each with its reason
UPWARD = {
    # a result's notebook view and .plot() draw it: the figures are the output layer's,
    # reached at call time (notebook and plots import no result class at run time)
    ("adavar.core.results", "adavar.output.notebook"),
}


def _layer(module: str) -> int | None:
    for k, (_, members) in enumerate(LAYERS):
        for member in members:
            if module == member or (
                member.endswith(".*") and (module == member[:-2] or module.startswith(member[:-1]))
            ):
                return k
    return None


def test_every_module_has_a_layer_and_imports_only_downwards():
    modules = {_module_name(path) for path in _modules()}
    assert [m for m in sorted(modules) if _layer(m) is None] == []
    upward = []
    for path, tree in _modules().items():
        here = _module_name(path)
        for target in sorted(_imports(path, tree, modules)):
            if _layer(target) > _layer(here) and (here, target) not in UPWARD:
                upward.append(f"{here} ({LAYERS[_layer(here)][0]}) imports {target} "
                              f"({LAYERS[_layer(target)][0]})")  # fmt: skip
    assert upward == []


# faces: added by the relayout (issue 41)
#: the public faces: documented module paths that re-export a module of a layer package
FACES = {
    "adavar.adaptive": "adavar.dynamic.adaptive",
    "adavar.analysis": "adavar.pipeline.analysis",
    "adavar.batch": "adavar.pipeline.batch",
    "adavar.datasets": "adavar.core.datasets",
    "adavar.demo": "adavar.pipeline.demo",
    "adavar.events": "adavar.dynamic.events",
    "adavar.export": "adavar.output.export",
    "adavar.io": "adavar.io.text_column",
    "adavar.long_tau": "adavar.dynamic.long_tau",
    "adavar.plots": "adavar.output.plots",
    "adavar.precompile": "adavar.pipeline.precompile",
    "adavar.report": "adavar.output.report",
    "adavar.report_parts": "adavar.output.report_parts",
    "adavar.settings": "adavar.core.settings",
    "adavar.stream": "adavar.stats.stream",
    "adavar.surface": "adavar.dynamic.surface",
    "adavar.surface_fit": "adavar.dynamic.surface_fit",
}
#: names a face gives beyond its module's __all__: documented in the API reference
FACE_EXTRAS = {"adavar.surface": {"davar_blocks"}}
#: faces of more than one module (``adavar.simulate``: the generators and the scenarios)
OTHER_FACES = {"adavar.simulate"}


def test_no_module_imports_a_public_face():
    """The library imports every name from the module that defines it; the faces
    (``adavar.plots``, ``adavar.simulate``, ...) are for users (the package ``adavar``
    itself and the faces excepted)."""
    faces = set(FACES) | OTHER_FACES
    modules = {_module_name(path) for path in _modules()}
    found = []
    for path, tree in _modules().items():
        here = _module_name(path)
        if here == "adavar" or here in faces:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module == "adavar":
                found += [f"{here}: adavar.{a.name}" for a in node.names
                          if f"adavar.{a.name}" in faces]  # fmt: skip
            elif isinstance(node, ast.ImportFrom) and node.module in faces:
                # ``from adavar.io import sources``: a module of the package, not the face
                found += [f"{here}: {node.module}.{a.name}" for a in node.names
                          if f"{node.module}.{a.name}" not in modules]  # fmt: skip
            elif isinstance(node, ast.Import):
                found += [f"{here}: {a.name}" for a in node.names if a.name in faces]
    assert found == []


def test_the_top_level_holds_the_faces_only():
    """A new module goes into its layer's package (``LAYERS``); the top level of the
    package holds the public faces (and ``adavar.comparison``, the paper layer's module
    that ``adavar.paper`` keeps outside itself), and ``adavar``'s lazy names point at the
    modules that define them."""
    import adavar

    top = {f"adavar.{path.stem}" for path in SRC.glob("*.py") if path.stem != "__init__"}
    assert top - {"adavar.comparison"} - OTHER_FACES == set(FACES) - {"adavar.io"}
    assert [m for m in adavar._LAZY.values() if m in FACES or m in OTHER_FACES] == []


@pytest.mark.parametrize("face", sorted(FACES))
def test_every_face_exports_exactly_its_modules_public_names(face):
    import importlib

    public = importlib.import_module(face)
    module = importlib.import_module(FACES[face])
    assert list(public.__all__) == list(module.__all__)
    assert [n for n in module.__all__ if getattr(public, n) is not getattr(module, n)] == []
    body = ast.parse(Path(public.__file__).read_text()).body
    defined = {
        node.name for node in body if isinstance(node, (ast.FunctionDef, ast.ClassDef))
    } - {"__getattr__", "__dir__"}  # fmt: skip
    defined |= {
        target.id for node in body if isinstance(node, (ast.Assign, ast.AnnAssign))
        for target in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(target, ast.Name) and target.id not in ("__all__", "_LAZY")
    }  # fmt: skip
    assert defined == set(), f"{face} defines {defined}: a face only re-exports"
    # and it gives nothing more than the module's __all__ (a name users would script
    # against that the module does not promise); the documented extras are listed
    if not hasattr(public, "__path__"):  # a package face also holds its submodules
        extra = {n for n in vars(public) if not n.startswith("_")} - set(module.__all__)
        assert extra <= FACE_EXTRAS.get(face, set()) | {"annotations"}, extra


def _top_level(body: list[ast.stmt]):
    """A module's top-level statements, those under ``if`` (``TYPE_CHECKING``) and ``try``."""
    for node in body:
        yield node
        if isinstance(node, ast.If):
            yield from _top_level(node.body)
            yield from _top_level(node.orelse)
        elif isinstance(node, ast.Try):
            yield from _top_level(node.body)


@cache
def _definitions() -> dict[str, tuple[frozenset[str], dict[str, tuple[str, str]]]]:
    """Per module: the names it defines, and those it imports (name -> module, name)."""
    out = {}
    for path, tree in _modules().items():
        defined: set[str] = set()
        imported: dict[str, tuple[str, str]] = {}
        for node in _top_level(tree.body):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                defined.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                defined.update(n.id for t in targets for n in ast.walk(t)
                               if isinstance(n, ast.Name))  # fmt: skip
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for alias in node.names:
                    imported[alias.asname or alias.name] = (node.module, alias.name)
        out[_module_name(path)] = (frozenset(defined), imported)
    return out


def _defined_in(module: str, name: str) -> str | None:
    """The module that defines ``name`` as ``module`` gives it (None: not followed)."""
    for _ in range(20):
        if module not in _definitions():
            return None
        defined, imported = _definitions()[module]
        if name in defined:
            return module
        if name not in imported or imported[name][1] != name:
            return None
        module = imported[name][0]
    return None


def test_the_library_imports_each_name_from_the_module_that_defines_it():
    """No module goes through another's re-exports (a shim the library would lean on): a
    name comes from where it is defined. The public faces, the readers' package (their
    documented face) and a module's deliberate re-exports (``noqa: F401``, ``name as name``)
    are the exceptions."""
    faces = set(FACES) | OTHER_FACES | {"adavar", "adavar.readers"}
    found = []
    for path, tree in _modules().items():
        here = _module_name(path)
        if here in faces:
            continue
        lines = path.read_text().splitlines()
        for node in ast.walk(tree):
            if not (isinstance(node, ast.ImportFrom) and node.module and not node.level):
                continue
            if node.module in faces or not node.module.startswith("adavar"):
                continue
            if "noqa: F401" in " ".join(lines[node.lineno - 1 : node.end_lineno]):
                continue
            for alias in node.names:
                if alias.asname == alias.name:
                    continue
                source = _defined_in(node.module, alias.name)
                if source is not None and source != node.module:
                    found.append(f"{here}:{node.lineno} takes {alias.name} from "
                                 f"{node.module}, defined in {source}")  # fmt: skip
    assert found == []
