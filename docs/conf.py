"""Sphinx configuration of the shells documentation site (built by scripts/build-docs)."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(REPO))

project = "shells"
author = "the shells developers"
copyright = "the shells developers"  # noqa: A001
release = version = "0.1.0"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip",
                    "gallery/*.md5", "gallery/*.json", "sg_execution_times.rst"]
html_theme = "furo"
html_title = "shells"
html_static_path: list[str] = []  # nothing of ours; MathJax is copied in by _copy_mathjax
templates_path: list[str] = []

# the equations are rendered by the MathJax 2 that Debian ships (libjs-mathjax), copied into
# the site: the pages need no network
MATHJAX = Path("/usr/share/javascript/mathjax")
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS_CHTML"

autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_google_docstring = True
napoleon_numpy_docstring = False

# The gallery: demos/*.py (percent format), executed in their quick mode at build time
# (SHELLS_DEMO_QUICK=1, outputs under docs/_build/demo-output); SHELLS_DOCS_RUN_DEMOS=0 builds
# the pages without running them (the browser test), plot_gallery off.
os.environ.setdefault("SHELLS_DEMO_QUICK", "1")
os.environ.setdefault("SHELLS_DEMO_OUT", str(DOCS / "_build" / "demo-output"))
os.environ.setdefault("MPLBACKEND", "Agg")
RUN_DEMOS = os.environ.get("SHELLS_DOCS_RUN_DEMOS", "1") != "0"
sphinx_gallery_conf = {
    "examples_dirs": [str(REPO / "demos")],
    "gallery_dirs": ["gallery"],
    "filename_pattern": r".*\.py$",
    "ignore_pattern": r"(main|__init__)\.py$",
    "plot_gallery": RUN_DEMOS,
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "show_signature": False,
}


def _copy_mathjax(app, exception) -> None:
    """MathJax 2's files that TeX-AMS_CHTML needs, into the site's _static/mathjax."""
    if exception is not None or app.builder.name != "html" or not MATHJAX.is_dir():
        return
    dest = Path(app.outdir) / "_static" / "mathjax"
    if (dest / "MathJax.js").exists():
        return
    for part in ("MathJax.js", "config", "extensions", "jax/input/TeX", "jax/output/CommonHTML",
                 "jax/element", "fonts/HTML-CSS/TeX/woff", "localization/en"):
        src = MATHJAX / part
        if src.is_dir():
            shutil.copytree(src, dest / part, dirs_exist_ok=True)
        elif src.exists():
            dest.joinpath(part).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / part)


def setup(app) -> None:
    app.connect("build-finished", _copy_mathjax)
