"""Shared by the command-line tests: run ``adavar`` in-process, check one-line errors."""

from __future__ import annotations

from adavar.cli import main


def run(capsys, argv):
    """Exit code, stdout and stderr of ``adavar ARGV`` run in this process."""
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, out, err, *fragments):
    """Exit 2, nothing on stdout, one ``adavar: error:`` line holding every fragment."""
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("adavar: error: ")
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


#: The library modules whose functions the commands import when they run (the command
#: modules import them inside their functions, so that ``adavar --help`` stays light).
LIBRARY = ("adavar.pipeline.analysis", "adavar.stats.statistics", "adavar.fit.noise_model",
           "adavar.dynamic.adaptive", "adavar.dynamic.surface", "adavar.output.export",
           "adavar.simulate")  # fmt: skip


def patch_cli(monkeypatch, name, value):
    """Set ``name`` to ``value`` in every ``adavar.cli`` module and in the library modules
    the commands take their functions from (:data:`LIBRARY`) that have it."""
    import importlib
    import pkgutil

    import adavar.cli

    hit = False
    names = [f"adavar.cli.{i.name}" for i in pkgutil.iter_modules(adavar.cli.__path__)]
    for module_name in [*LIBRARY, *names]:  # the pipeline the commands call, too
        if module_name.endswith("__main__"):
            continue
        module = importlib.import_module(module_name)
        if hasattr(module, name):
            monkeypatch.setattr(module, name, value)
            hit = True
    assert hit, f"no adavar.cli module has {name!r}"
