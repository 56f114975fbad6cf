"""Packaging checks that need no build: the version's single source, package data, imports.

Building and installing the wheel is too slow for the suite; CONTRIBUTING.md ("Releasing")
has that check. These tests catch what breaks it: a version defined twice, a data file the
wheel would leave out, a package directory without ``__init__.py`` (setuptools' package
discovery skips it, so its modules are missing from the wheel), and ``adavar --version``
or ``--help`` importing the heavy libraries.
"""

from __future__ import annotations

import fnmatch
import importlib.metadata
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import adavar

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "adavar"
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))

# written beside the sources at run time (bytecode, Numba's on-disk cache), never shipped
GENERATED = ("*.pyc", "*.pyo", "*.nbi", "*.nbc")
# reaching a file through the package's own location
PACKAGE_FILE_ACCESS = re.compile(
    r"importlib\.resources|importlib_resources|pkgutil\.get_data|pkg_resources|__file__"
)
FILE_NAME = re.compile(r"""["']([\w./-]+\.[A-Za-z0-9]{1,5})["']""")


def _package_data_patterns() -> list[str]:
    setuptools = PYPROJECT.get("tool", {}).get("setuptools", {})
    data = setuptools.get("package-data", {})
    return [*data.get("adavar", []), *data.get("*", [])]


def _declared(relative: Path) -> bool:
    # setuptools matches package-data globs against the path inside the package
    name = relative.as_posix()
    return any(fnmatch.fnmatch(name, pattern) for pattern in _package_data_patterns())


def _shipped_files() -> list[Path]:
    files = []
    for path in PACKAGE.rglob("*"):
        if not path.is_file() or "__pycache__" in path.parts:
            continue
        if any(fnmatch.fnmatch(path.name, pattern) for pattern in GENERATED):
            continue
        files.append(path.relative_to(PACKAGE))
    return files


def test_version_is_defined_once():
    project = PYPROJECT["project"]
    assert "version" not in project, "pyproject.toml must not repeat the version"
    assert "version" in project.get("dynamic", [])
    dynamic = PYPROJECT["tool"]["setuptools"]["dynamic"]["version"]
    assert dynamic == {"attr": "adavar.__version__"}
    assert re.fullmatch(r"\d+\.\d+\.\d+(?:[a-z]+\d+)?(?:\.dev\d+)?", adavar.__version__)


def test_installed_metadata_matches_the_package():
    installed = importlib.metadata.version("adavar")
    assert installed == adavar.__version__, (
        f"the installed metadata says {installed}, adavar.__version__ {adavar.__version__}: "
        "reinstall (pip install -e .) after changing the version"
    )


def test_version_flag_prints_the_metadata_version(tmp_path):
    # from outside the source tree, so that the installed package answers
    done = subprocess.run(
        [sys.executable, "-m", "adavar.cli", "--version"],
        capture_output=True, text=True, cwd=tmp_path, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"adavar {importlib.metadata.version('adavar')}"


def test_help_and_version_stay_light(tmp_path):
    code = (
        "import contextlib, io, sys\n"
        "from adavar.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    assert main(['--help']) == 0 and main(['--version']) == 0\n"
        "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    heavy = {"scipy", "numba", "matplotlib", "dask", "distributed", "plotly", "pandas",
             "pyarrow", "h5py", "xarray"}  # fmt: skip
    assert not loaded & heavy, f"adavar --help imports {sorted(loaded & heavy)}"


def test_py_typed_is_shipped():
    assert (PACKAGE / "py.typed").is_file()
    assert _declared(Path("py.typed"))


def test_every_data_file_of_the_package_is_declared():
    undeclared = [str(p) for p in _shipped_files() if p.suffix != ".py" and not _declared(p)]
    assert not undeclared, (
        f"files under src/adavar that the wheel would leave out: {undeclared}; add them to "
        "[tool.setuptools.package-data] in pyproject.toml"
    )


def test_files_the_code_opens_from_the_package_are_declared():
    missing = []
    for module in PACKAGE.rglob("*.py"):
        text = module.read_text(encoding="utf-8")
        if not PACKAGE_FILE_ACCESS.search(text):
            continue
        for name in FILE_NAME.findall(text):
            if name.endswith(".py"):
                continue
            candidates = [p for p in _shipped_files() if p.as_posix().endswith(name)]
            if candidates and not all(_declared(p) for p in candidates):
                missing.append(f"{module.relative_to(ROOT)}: {name}")
    assert not missing, f"package files opened at run time but not declared: {missing}"


def test_every_package_directory_is_a_package():
    # setuptools' find_packages only takes directories with an __init__.py
    orphans = [
        str(d.relative_to(ROOT))
        for d in [PACKAGE, *(p for p in PACKAGE.rglob("*") if p.is_dir())]
        if "__pycache__" not in d.parts
        and any(d.glob("*.py"))
        and not (d / "__init__.py").is_file()
    ]
    assert not orphans, f"directories of modules the wheel would leave out: {orphans}"


def test_console_script_entry_point():
    scripts = PYPROJECT["project"]["scripts"]
    # run() is main() and then an exit that skips the interpreter's final collection
    assert scripts == {"adavar": "adavar.cli:run"}
    entry = [e for e in importlib.metadata.entry_points(group="console_scripts")
             if e.name == "adavar"]  # fmt: skip
    assert entry and entry[0].value == "adavar.cli:run"
    from adavar.cli import main, run

    assert callable(main) and callable(run)
