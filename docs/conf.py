"""Sphinx configuration of the hoprover documentation site.

Build (from the repository root):
    .venv/bin/pip install -e ".[docs]"
    .venv/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

docs/*.md stay Markdown (MyST). The environment pages are written from the env modules'
docstrings at read time (docs/_ext/envpages.py); their animations and the tutorials
(examples/tutorials, sphinx-gallery) are produced by running the code during the build.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# the repository first: the tutorials and the API pages document this checkout (not an
# installed copy), and docs/_ext holds the site's own extensions
sys.path[:0] = [str(ROOT), str(DOCS / "_ext")]
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import hoprover_env  # noqa: E402

project = "hoprover"
author = "the hoprover developers"
copyright = "2026, the hoprover developers"
release = version = hoprover_env.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.viewcode",
    "sphinx_copybutton",
    "sphinx_gallery.gen_gallery",
    "envpages",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "_generated/*.md",
    "tutorials/*.md5",
    "tutorials/*.ipynb",
    "tutorials/*.zip",
    "tutorials/*.py",
    "tutorials/*.json",
]

myst_enable_extensions = ["colon_fence", "deflist", "attrs_inline", "attrs_block"]
myst_heading_anchors = 3

# docstrings: `name` links to the Python object when there is one (rendered as code either way)
default_role = "py:obj"
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_inherit_docstrings = False  # gymnasium's / SB3's docstrings are not ours
autodoc_default_options = {"show-inheritance": True}
autosummary_generate = False
# hoprover_env.envs.rllib needs Ray, an optional extra ([ray]): document it without importing Ray
autodoc_mock_imports = ["ray"]

html_theme = "furo"
html_title = f"hoprover {release}"
html_static_path = ["_static"]
html_css_files = ["hoprover.css"]
html_theme_options = {"navigation_with_keys": True}
copybutton_prompt_text = r">>> |\.\.\. |\$ "
copybutton_prompt_is_regexp = True

# ---- tutorials: run at build time -------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": [str(ROOT / "examples" / "tutorials")],
    "gallery_dirs": ["tutorials"],
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "min_reported_time": 0,
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "reset_modules": ("matplotlib",),
    "capture_repr": ("_repr_html_", "__repr__"),
}
