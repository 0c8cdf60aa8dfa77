"""Sphinx configuration of the breachflow user guide (MyST Markdown pages + the API reference from the
docstrings).

    sphinx-build -W --keep-going -n -b html docs docs/_build/html   # what tests/test_docs.py runs

``-W`` makes every warning an error; ``-n`` (nitpicky) makes every cross-reference to breachflow that does
not resolve an error; references into other packages (numpy, xarray, pint, ...) are not checked (no
intersphinx: the build is offline). Pages are MyST Markdown (myst-parser); ``api.rst`` is reStructuredText.
"""
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))

project = "breachflow"
author = "breachflow developers"
copyright = "2026, breachflow developers"


def _version() -> str:
    """The version in pyproject.toml (one place), else the installed package's."""
    pyproject = ROOT / "pyproject.toml"
    if pyproject.exists():
        return re.search(r'^version\s*=\s*"([^"]+)"', pyproject.read_text(encoding="utf-8"), re.M).group(1)
    from importlib.metadata import version as installed

    return installed("breachflow")


release = version = _version()

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.mathjax"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
myst_enable_extensions = ["dollarmath", "amsmath", "deflist"]
myst_heading_anchors = 3
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
html_theme = "alabaster"
html_static_path: list[str] = []
suppress_warnings = ["ref.python"]  # several classes re-exported under package names: "more than one target"

# Not checked: names of other packages and Python builtins (no network for intersphinx), typing aliases.
_EXTERNAL = (r"(xr|xarray|np|numpy|numpy\.typing|pint|pd|pandas|pathlib|Path|typing|collections\.abc|dask|"
             r"distributed|matplotlib|pyproj|rich|typer|scipy|numba|netCDF4|datetime|enum|dataclasses)(\..*)?")
nitpick_ignore_regex = [
    (r"py:.*", _EXTERNAL),
    (r"py:.*", r"(Dataset|DataArray|ndarray|Quantity|Unit|UnitRegistry|Path|Any|Callable|Iterable|Sequence|"
               r"Mapping|Optional|Union|Literal|Self|ArrayLike|NDArray|optional|callable|array_like|array-like)"),
    (r"py:.*", r"breachflow\.registry\.T"),  # the registry's TypeVar
    (r"py:.*", r"(int|float|str|bool|bytes|dict|list|tuple|set|object|type|None|complex|Exception|ValueError|"
               r"TypeError|KeyError|Warning|UserWarning|RuntimeError|OSError|FileNotFoundError)"),
]

# The toctree of index.md lists the guide's pages by name. Its "Topics" section ends with the marker line
# below; every other page in docs/ (a new topic page) is listed there at build time, so a new page never
# breaks the build for want of a toctree entry. Add pages by name above the marker to choose their order.
TOPICS_MARKER = "% further topic pages are inserted here at build time (conf.py: _list_other_pages)"


def _listed(text: str) -> set[str]:
    return {line.strip() for line in text.splitlines()}


def _list_other_pages(app, docname, source):
    if docname != root_doc or TOPICS_MARKER not in source[0]:
        return
    here = Path(app.srcdir)
    listed = _listed(source[0])
    pages = sorted(p.relative_to(here).with_suffix("").as_posix() for p in here.glob("*.md"))
    pages += sorted(p.relative_to(here).with_suffix("").as_posix() for p in here.glob("*.rst"))
    extra = [p for p in pages if p != root_doc and p not in listed]
    source[0] = source[0].replace(TOPICS_MARKER, "\n".join(extra))


def setup(app):
    app.connect("source-read", _list_other_pages)
