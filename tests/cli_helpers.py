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
