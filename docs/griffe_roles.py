"""A griffe extension for mkdocstrings: vilma's docstrings use Sphinx roles and ``::``, shown here as Markdown.

``:class:`~vilma.sim.Simulator``` becomes ```Simulator``` (```vilma.sim.Simulator``` without the ``~``), and a
paragraph ending in ``::`` ends in ``:`` (the indented block after it is code in Markdown too). Roles become
plain code rather than links because many of their targets (``vilma.core``, ``vilma.sensors``) have no page.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|func|meth|attr|data|mod|exc|obj):`(~?)([\w.]+)`")
LITERAL = re.compile(r"::$", re.MULTILINE)


def markdown(text: str) -> str:
    """``text`` with each Sphinx role as inline code and each ``::`` line end as ``:``."""
    text = ROLE.sub(lambda m: f"`{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}`", text)
    return LITERAL.sub(":", text)


class SphinxRoles(griffe.Extension):
    """Rewrites the docstrings of a loaded package (see :func:`markdown`)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        todo: list[griffe.Object] = [pkg]
        while todo:
            obj = todo.pop()
            if obj.docstring is not None:
                obj.docstring.value = markdown(obj.docstring.value)
            todo.extend(m for m in obj.members.values() if not m.is_alias)
