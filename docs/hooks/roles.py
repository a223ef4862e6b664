"""Sphinx roles in docstrings (``:func:`x```, ``:class:`~a.B```) rendered as code, not as
raw text: mkdocstrings's numpy-style renderer keeps them verbatim."""

import re

ROLE = r":(?:func|class|meth|mod|attr|data|obj|exc):"
_IN_TEXT = re.compile(ROLE + r"(<code>)")  # prose: the role, then the rendered inline code
_RAW = re.compile(ROLE + r"`~?\.?([^`]+)`")  # inside a rendered code span: the role and its backticks


def on_page_content(html, page, config, files):
    html = _IN_TEXT.sub(r"\1", html)
    return _RAW.sub(lambda m: m.group(1).rsplit(".", 1)[-1] if "~" in m.group(0) else m.group(1), html)
