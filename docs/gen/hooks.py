"""MkDocs hooks of the documentation build (``hooks:`` in mkdocs.yml).

The tutorials' code blocks run at build time (markdown-exec). These hooks give them

- the ``adavar`` command of the Python that runs MkDocs (``.venv/bin/mkdocs`` need not be
  on ``PATH``), a non-interactive matplotlib backend and a fixed terminal width;
- a fresh scratch folder per page: a block's ``workdir="NAME"`` is rewritten to
  ``<build scratch>/NAME``, created empty before the page runs, so the commands shown
  (``adavar avar gyro.csv ...``) read and write there, never in the source tree.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

_WORKDIR = re.compile(r'workdir="([A-Za-z0-9_-]+)"')
_scratch: Path | None = None
_started: dict[str, float] = {}
_log = logging.getLogger("mkdocs.hooks.adavar")


def on_config(config: Any, **kwargs: Any) -> Any:
    global _scratch
    _clean()
    bindir = str(Path(sys.executable).parent)
    os.environ["PATH"] = bindir + os.pathsep + os.environ.get("PATH", "")
    os.environ["MPLBACKEND"] = "Agg"
    os.environ["COLUMNS"] = "100"
    os.environ.setdefault("PYTHONHASHSEED", "0")
    _scratch = Path(tempfile.mkdtemp(prefix="adavar-docs-"))
    return config


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    assert _scratch is not None
    _started[page.file.src_uri] = time.perf_counter()

    def absolute(match: re.Match[str]) -> str:
        folder = _scratch / match.group(1)
        folder.mkdir(exist_ok=True)
        return f'workdir="{folder}"'

    return _WORKDIR.sub(absolute, markdown)


_ROLE_HTML = re.compile(r":(?:func|class|mod|data|attr|meth|exc|obj):(<code>)")


def on_page_content(html: str, page: Any, **kwargs: Any) -> str:
    started = _started.pop(page.file.src_uri, None)
    if started is not None:  # `mkdocs build -v` shows what each page's code blocks cost
        _log.debug("%s rendered in %.1f s", page.file.src_uri, time.perf_counter() - started)
    # a role the docstring extension could not turn into a link (e.g. inside a table cell)
    return _ROLE_HTML.sub(r"\1", html)


def _clean(**kwargs: Any) -> None:
    # the scratch folders hold the tutorials' data (some 200 MB): removed however it ends
    global _scratch
    if _scratch is not None:
        shutil.rmtree(_scratch, ignore_errors=True)
        _scratch = None


on_post_build = on_build_error = on_shutdown = _clean
