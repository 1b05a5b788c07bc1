"""Sphinx configuration of the wrinkle-vis documentation site (``bash scripts/docs.sh``).

Markdown pages through MyST, the API reference from the numpydoc docstrings, equations
by MathJax served from the site itself (``sphinx-mathjax-offline``: MathJax 3 and its fonts
are copied into ``_static/mathjax``; nothing is fetched from a CDN, at build or view time)
and a gallery of examples run by sphinx-gallery, their scenes captured by PyVista's scraper.
"""

import os
import sys
from pathlib import Path

import pyvista as pv

import wrinkle_vis

DOCS = Path(__file__).resolve().parent
#: Where the examples find the real scan (``lee_perry_smith_head.obj``): the workspace's
#: ``shared/realmeshes`` beside the repository unless ``$WRINKLE_VIS_REALMESHES`` says.
os.environ.setdefault("WRINKLE_VIS_REALMESHES",
                      str(DOCS.parent.parent / "shared" / "realmeshes"))

# ---------------------------------------------------------------------- PyVista
pv.set_plot_theme("document")
pv.global_theme.window_size = [800, 600]
pv.global_theme.anti_aliasing = "ssaa"
pv.OFF_SCREEN = True
pv.BUILDING_GALLERY = True  # plotters stay open for the scraper

# ---------------------------------------------------------------------- project
project = "wrinkle-vis"
author = "the wrinkle-vis developers"
copyright = "the wrinkle-vis developers, MIT licence"  # noqa: A001
release = version = wrinkle_vis.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# gallery/ holds the examples' sources (sphinx-gallery reads them), auto_examples/ the pages
# made from them; examples/ and notebooks/ are not pages
exclude_patterns = ["_build", "gallery", "examples", "notebooks"]

# ---------------------------------------------------------------------- Markdown
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# ---------------------------------------------------------------------- API reference
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc sections say the types
autodoc_default_options = {"members": True, "show-inheritance": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()



def _write_parameter_tables() -> None:
    """``api/parameters.md``: every installed muscle type's parameters, made from their
    declared metadata (:func:`wrinkle_vis.core.params.parameter_table`) at each build.
    """
    from wrinkle_vis.core.params import TABLE_COLUMNS, parameter_table

    lines = ["# Muscle parameters", "",
             "Made at build time from each installed type's declared parameters "
             "(`wrinkle-vis types --markdown` prints the same). Lengths are in the face's "
             "units (mm on the built-in face); *derived* parameters may be left out (null), "
             "and then take the value the others give them.", ""]
    for name, cls in wrinkle_vis.muscle_types().items():
        lines += [f"## {name}", "", f"`{cls.__module__}.{cls.__qualname__}`", "",
                  "| " + " | ".join(TABLE_COLUMNS) + " |", "|" + "---|" * len(TABLE_COLUMNS)]
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |"
                  for row in parameter_table(cls)]
        lines.append("")
    text = "\n".join(lines)
    target = DOCS / "api" / "parameters.md"
    if not target.is_file() or target.read_text(encoding="utf-8") != text:
        target.write_text(text, encoding="utf-8")


_write_parameter_tables()

# ---------------------------------------------------------------------- math
# sphinx-mathjax-offline sets mathjax_path to its copy; said here too so that it is plain
mathjax_path = "mathjax/tex-chtml.js"

# ---------------------------------------------------------------------- gallery
sphinx_gallery_conf = {
    "examples_dirs": ["gallery"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"plot_",
    "image_scrapers": ("pyvista",),  # pyvista.Scraper
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "capture_repr": ("_repr_html_",),
    "matplotlib_animations": False,
    "show_memory": False,
    "write_computation_times": False,  # its page loads jQuery and DataTables from CDNs
    "show_signature": False,
    "reset_modules": (),
    "promote_jupyter_magic": False,
    "default_thumb_file": str(DOCS / "images" / "W_surprise.png"),
}

# ---------------------------------------------------------------------- HTML
html_theme = "pydata_sphinx_theme"
html_title = "wrinkle-vis"
html_theme_options = {
    "navigation_with_keys": False,
    "show_prev_next": False,
    "header_links_before_dropdown": 4,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
# wide-math.css: a display equation wider than the column scrolls instead of being cut off
html_static_path = ["_static"]
html_css_files = ["wide-math.css"]
html_last_updated_fmt = None
html_copy_source = False
html_show_sourcelink = False

sys.dont_write_bytecode = True


def _elided_json(app, what, name, obj, options, lines):
    """A ``json`` code block with ``...`` elisions is not JSON (Pygments refuses it, a
    warning): show it as JavaScript, which reads the same.
    """
    for i, line in enumerate(lines):
        if line.strip() == ".. code-block:: json":
            body = []
            for following in lines[i + 1:]:
                if following.strip() and not following.startswith(" "):
                    break
                body.append(following)
            if "..." in "\n".join(body):
                lines[i] = line.replace("json", "javascript")


def setup(app):
    """Sphinx's hook: connect :func:`_elided_json`."""
    app.connect("autodoc-process-docstring", _elided_json)
