"""Write the home page (``index.md``) from README.md's introduction (mkdocs-gen-files).

The introduction is README's text between its ``---`` rule and its first section after it
(``## Example``), so the site and the README say the same and only README is edited.
"""

from __future__ import annotations

from pathlib import Path

import mkdocs_gen_files

README = Path(__file__).resolve().parents[2] / "README.md"

ROWS = [
    ("a log of a MEMS gyro or accelerometer", "Getting started: a MEMS gyro",
     "getting-started/gyro.md"),
    ("phase or frequency data of a clock", "Getting started: a clock",
     "getting-started/clock.md"),
    ("a static IMU log for Kalibr", "Whole-record fit to a Kalibr imu.yaml",
     "tutorials/kalibr.md"),
    ("a log whose noise changes", "DAVAR of a disturbed log", "tutorials/davar.md"),
    ("a log whose noise changes, and its events", "A-DAVAR and its events",
     "tutorials/adaptive.md"),
    ("thousands of logs", "A batch on a cluster", "tutorials/batch.md"),
    ("one record larger than memory", "Records larger than memory",
     "tutorials/large-records.md"),
]  # fmt: skip

NEXT = (
    "\n## Where to go next\n\n| if you have | read |\n|---|---|\n"
    + "".join(f"| {have} | [{title}]({page}) |\n" for have, title, page in ROWS)
    + """
The equations and every default are in [the method](method.md); the paper's results
side by side with adavar's in [the paper, reproduced](paper.md); speed and accuracy in
[the benchmarks](benchmarks.md). Every command and flag: [the command line](reference/cli.md);
every function: [the API](reference/api/index.md); figures: [the gallery](gallery/index.md);
every feature, command and library call in one page: [using adavar](usage.md).

Install from a checkout, `python3 -m venv .venv && .venv/bin/pip install -e .` (Python 3.11
or newer; the extra `".[data]"` adds the readers of HDF5, Parquet and ROS bags), or
`pip install` the wheel that `python -m build` makes. The first call compiles the Numba
kernels (about 20 s); they are cached on disk after that.
"""
)


def intro(text: str) -> str:
    lines = text.splitlines()
    start = lines.index("---") + 1
    stop = next(i for i in range(start, len(lines)) if lines[i].startswith("## "))
    return "\n".join(lines[start:stop]).strip()


with mkdocs_gen_files.open("index.md", "w") as fh:
    fh.write("# adavar\n\n" + intro(README.read_text(encoding="utf-8")) + "\n" + NEXT)
mkdocs_gen_files.set_edit_path("index.md", "../README.md")
