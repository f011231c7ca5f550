# Sphinx configuration of the Python API reference (issue 26). tools/docs.sh runs
#   python3 -m sphinx -W --keep-going -b html docs/api $NONHOLO_BUILD/docs/python
# with NONHOLO_BUILD set, so that autodoc imports the package as built there (nonholo and its
# compiled nonholo._core), not an installed one. Every warning fails the build (-W).
import os
import sys

_build = os.environ.get("NONHOLO_BUILD")
if not _build:
    raise RuntimeError("docs/api/conf.py: set NONHOLO_BUILD to the build tree (tools/docs.sh does)")
sys.path.insert(0, os.path.join(os.path.abspath(_build), "python"))

import nonholo  # noqa: E402  (the package as built: a failed import is an error, not a skip)

project = "nonholo"
author = "the nonholo authors"
copyright = "the nonholo authors, BSD-3-Clause"
version = release = nonholo.__version__

extensions = ["sphinx.ext.autodoc"]
master_doc = "index"
source_suffix = ".rst"
exclude_patterns = ["Doxyfile", "mainpage.md", "_build"]

# The docstrings are the API's own text: members in source order, signatures as the compiled
# module states them (pybind11 writes them into the first docstring line).
default_role = "code"  # `name` in a docstring is code, as in the C++ comments
autodoc_member_order = "bysource"
autodoc_docstring_signature = True
autodoc_typehints = "signature"
autoclass_content = "both"

html_theme = "alabaster"
html_title = "nonholo %s: Python API" % release
html_static_path = []
