"""Fail the build when a public name of ``adavar`` has no entry in the API reference.

Every name of ``adavar.__all__`` must appear as a mkdocstrings directive
(``::: adavar.NAME``, or ``::: adavar.NAME.something`` for a module) in a page under
``reference/api/``: a new public function is documented, or the build says which one is
not.
"""

from __future__ import annotations

import re
from pathlib import Path

import adavar

API = Path(__file__).resolve().parents[1] / "reference" / "api"

directives = set()
for page in API.glob("*.md"):
    directives.update(re.findall(r"^::: (\S+)", page.read_text(encoding="utf-8"), re.M))
missing = [
    name
    for name in adavar.__all__
    if f"adavar.{name}" not in directives
    and not any(d.startswith(f"adavar.{name}.") for d in directives)
]
if missing:
    raise RuntimeError(
        f"public names without an API entry: {missing}; add '::: adavar.NAME' to a page "
        "of docs/reference/api/"
    )
