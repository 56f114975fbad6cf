"""A Griffe extension for the API reference: adavar's docstrings in Markdown.

adavar's docstrings are numpydoc, written to read well in ``help()``: Sphinx roles
(``:func:`deviation```), reStructuredText simple tables and ``.. math::`` blocks. Before
mkdocstrings renders them as Markdown, this extension rewrites

- a role into a link to the object when the site documents it (an optional cross-reference:
  plain code, and no warning, when it does not);
- a simple table into a Markdown table;
- a ``.. math::`` block into a code block.

Only the text handed to the renderer changes; the source files are not touched.
"""

from __future__ import annotations

import html
import re
from typing import Any

from griffe import Extension, Object

_ROLE = re.compile(r":(?:py:)?(?:func|class|mod|data|attr|meth|exc|obj|const):`~?([^`]+)`")
_RULE = re.compile(r"^(\s*)(=+)((?:\s+=+)+)\s*$")


def _role(match: re.Match[str], module: str) -> str:
    target = match.group(1).strip()
    text = target.split(".")[-1] if match.group(0).split("`")[1].startswith("~") else target
    if "<" in target and target.endswith(">"):  # :func:`title <target>`
        text, target = (part.strip() for part in target[:-1].split("<", 1))
    target = target.rstrip("()")
    if "." not in target and not target.startswith("adavar"):
        target = f"{module}.{target}"
    return (
        f'<autoref identifier="{html.escape(target)}" optional>'
        f"<code>{html.escape(text)}</code></autoref>"
    )


def _columns(rule: str) -> list[tuple[int, int]]:
    return [(m.start(), m.end()) for m in re.finditer(r"=+", rule)]


def _cells(line: str, spans: list[tuple[int, int]]) -> list[str]:
    cells = []
    for k, (start, _end) in enumerate(spans):
        stop = spans[k + 1][0] if k + 1 < len(spans) else len(line)
        cells.append(line[start:stop].strip().replace("|", "\\|"))
    return cells


def _tables(text: str) -> str:
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        rule = _RULE.match(lines[i])
        if rule is None:
            out.append(lines[i])
            i += 1
            continue
        indent = rule.group(1)
        spans = _columns(lines[i])
        rows: list[list[str]] = []
        rules = 1
        j = i + 1
        while j < len(lines) and lines[j].strip():
            if _RULE.match(lines[j]):
                rules += 1
            elif rows and len(spans) > 1 and not lines[j][: spans[1][0]].strip():
                # a continuation line: its first cell is empty
                for k, cell in enumerate(_cells(lines[j], spans)):
                    if cell:
                        rows[-1][k] = f"{rows[-1][k]} {cell}".strip()
            else:
                rows.append(_cells(lines[j], spans))
            j += 1
            if rules == 3:
                break
        if rules < 2 or not rows:
            out.append(lines[i])
            i += 1
            continue
        header, body = (rows[0], rows[1:]) if rules == 3 else ([""] * len(spans), rows)
        out.append("")
        out.append(indent + "| " + " | ".join(header) + " |")
        out.append(indent + "|" + "---|" * len(spans))
        out.extend(indent + "| " + " | ".join(row) + " |" for row in body)
        out.append("")
        i = j
    return "\n".join(out)


def _math(text: str) -> str:
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        m = re.match(r"^(\s*)\.\. math::\s*(.*)$", line)
        if m is None:
            out.append(line)
            i += 1
            continue
        indent, first = m.groups()
        body = [first] if first.strip() else []
        i += 1
        while i < len(lines) and (not lines[i].strip() or lines[i].startswith(indent + " ")):
            body.append(lines[i].strip())
            i += 1
        while body and not body[-1]:
            body.pop()
        out.extend([f"{indent}```text", *(indent + b for b in body), f"{indent}```", ""])
    return "\n".join(out)


class SphinxToMarkdown(Extension):
    """Rewrites roles, simple tables and math blocks of every docstring (see the module)."""

    def on_instance(self, *, obj: Object, **kwargs: Any) -> None:
        if obj.docstring is None:
            return
        module = obj.module.path if obj.is_module is False else obj.path
        text = obj.docstring.value
        text = _math(_tables(text))
        obj.docstring.value = _ROLE.sub(lambda m: _role(m, module), text)
