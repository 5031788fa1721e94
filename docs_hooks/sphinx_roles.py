"""MkDocs hook: the Sphinx roles of the docstrings (``:func:`name```) as cross-references.

The docstrings are written in the numpy style with Sphinx roles, which the numpy style renders
as the role's name before a code span (``:func:<code>name</code>``). This hook turns each into
an optional mkdocs-autorefs reference: a link to the object's API entry where it has one, the
code span alone where it does not. ``~a.b.c`` shows ``c``, as in Sphinx. A literal block
introduced by ``::`` keeps one colon.
"""

from __future__ import annotations

import re

ROLE = re.compile(r":(?:py:)?(?:mod|func|class|meth|attr|data|exc|obj|const):<code>(~?)([\w.]+?)(\(\))?</code>")
DOUBLE_COLON = re.compile(r"([^:\s])::(\s*</p>)")


def _reference(m: re.Match[str]) -> str:
    tilde, identifier, call = m.group(1), m.group(2), m.group(3) or ""
    title = identifier.rsplit(".", 1)[-1] if tilde else identifier
    return f'<autoref identifier="{identifier}" optional><code>{title}{call}</code></autoref>'


def on_page_content(html: str, **kwargs: object) -> str:
    """Rewrite the roles of one page (before autorefs resolves the references)."""
    return DOUBLE_COLON.sub(r"\1:\2", ROLE.sub(_reference, html))
