"""Build the gallery at build time (mkdocs-gen-files): run each example, save its figure.

Every ``gallery/NN_name.py`` beside this script is a short, self-contained example on
simulated data that leaves a matplotlib figure in ``fig``. Each is run here, its figure
saved with :func:`adavar.plots.save_figure` into the built site (``gallery/NN_name.png``),
and ``gallery/index.md`` shows each figure with the code that drew it (the file itself,
less its docstring, which becomes the title and the text). An example that fails fails
the build.
"""

from __future__ import annotations

import ast
import os
import runpy
import time
from pathlib import Path

import mkdocs_gen_files

from adavar.plots import save_figure

EXAMPLES = Path(__file__).resolve().parent / "gallery"
DPI = 110


def _parts(path: Path) -> tuple[str, str, str]:
    """Title, description and code (without the docstring) of an example."""
    source = path.read_text(encoding="utf-8")
    module = ast.parse(source)
    doc = ast.get_docstring(module) or path.stem
    title, _, text = doc.partition("\n")
    body = module.body[0]
    code_lines = source.splitlines()[body.end_lineno :]
    return title.strip().rstrip("."), text.strip(), "\n".join(code_lines).strip()


def build() -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
    editor = mkdocs_gen_files.FilesEditor.current()
    target = Path(editor.directory) / "gallery"
    target.mkdir(parents=True, exist_ok=True)
    page = [
        "# Gallery",
        "",
        "Every figure on this page was drawn when the site was built, by the code beside "
        "it (simulated data, so each example runs as it stands in a few seconds). The "
        "figures are those the commands write with `--out` and those of `adavar.plots`.",
        "",
    ]
    for path in sorted(EXAMPLES.glob("[0-9]*.py")):
        title, text, code = _parts(path)
        started = time.perf_counter()
        namespace = runpy.run_path(str(path), run_name="__gallery__")
        fig = namespace.get("fig")
        if fig is None:
            raise RuntimeError(f"gallery example {path.name} left no figure in 'fig'")
        # a new file of the build (an empty one), then the figure written over it
        mkdocs_gen_files.open(f"gallery/{path.stem}.png", "wb").close()
        save_figure(fig, target / path.stem, formats=("png",), dpi=DPI)
        seconds = time.perf_counter() - started
        page += [
            f"## {title}",
            "",
            text,
            "",
            f"![{title}]({path.stem}.png)",
            "",
            f'```python title="{path.name} ({seconds:.1f} s)"',
            code,
            "```",
            "",
        ]
    with mkdocs_gen_files.open("gallery/index.md", "w") as fh:
        fh.write("\n".join(page))


build()
