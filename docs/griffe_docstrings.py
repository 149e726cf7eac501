"""Griffe extension (docs/mkdocs.yml): the docstrings of wbc are written with Sphinx roles
(:class:`~wbc.tasks.ComTask`) and plain-text maths (v*_i, a*_i) that Markdown would misread. Before mkdocstrings
renders a docstring, a role becomes inline code of its target (the last component when the target starts with
``~``), and an asterisk right after a letter, digit or bracket (a superscript star, not emphasis) is escaped —
outside inline code and outside indented blocks (the docstrings' equations, rendered as code)."""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:py:)?(?:class|mod|func|meth|attr|data|exc|obj|const):`(~?)([^`]+)`")
STAR = re.compile(r"(?<=[\w)\]])\*")


def _role(match: re.Match) -> str:
    target = match.group(2)
    return f"`{target.rsplit('.', 1)[-1] if match.group(1) else target}`"


def _line(line: str) -> str:
    if line.startswith("    ") or line.startswith("\t"):
        return line  # an indented block: rendered verbatim
    parts = line.split("`")
    for i in range(0, len(parts), 2):  # even parts are outside inline code
        parts[i] = STAR.sub(r"\\*", parts[i])
    return "`".join(parts)


def clean(text: str) -> str:
    return "\n".join(_line(line) for line in ROLE.sub(_role, text).split("\n"))


class SphinxRolesToMarkdown(griffe.Extension):
    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = clean(obj.docstring.value)
