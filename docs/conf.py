"""Sphinx configuration: the API reference from the docstrings, and the Markdown docs.

Build (warnings are errors, as in CI): ``sphinx-build -W -b html docs docs/_build/html``.
"""

import importlib.metadata

project = "crumple"
author = "crumple developers"
release = importlib.metadata.version("crumple")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",  # the docstrings are NumPy style
    "sphinx.ext.mathjax",
    "myst_parser",  # the docs are Markdown
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build"]

autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
myst_heading_anchors = 3

html_theme = "alabaster"
html_title = f"crumple {release}"

# --------------------------------------------------------------------------------------------
# crumple.energy and crumple.minimize write absolute values as |x| in plain-text docstrings,
# which reStructuredText reads as substitutions. Those two modules are being rewritten
# (issue 9); until then their docstrings are escaped here, for them only. Remove this hook
# once their docstrings write ``|x|`` or :math:`|x|`.
import re  # noqa: E402

_ABS = re.compile(r"(?<![\\|`])\|([^|`\s][^|`]*?)\|(?!`)")


def _escape_abs(app, what, name, obj, options, lines):
    if not name.startswith(("crumple.energy", "crumple.minimize")):
        return
    for i, line in enumerate(lines):
        if "\\" not in line:  # leave .. math:: lines alone
            lines[i] = _ABS.sub(r"\\|\1\\|", line)


def setup(app):
    app.connect("autodoc-process-docstring", _escape_abs)
