"""Sphinx configuration of the breachflow API reference (built from the docstrings).

    sphinx-build -W --keep-going -n -b html docs docs/_build/html   # what tests/test_docs.py runs

``-n`` (nitpicky) makes every cross-reference to breachflow that does not resolve an error; references
into other packages (numpy, xarray, pint, ...) are not checked (no intersphinx: the build is offline).
"""
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))

project = "breachflow"
author = "breachflow developers"
copyright = "2026, breachflow developers"
release = version = "0.1.0"

extensions = ["sphinx.ext.autodoc"]
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
napoleon_google_docstring = True
napoleon_numpy_docstring = True
exclude_patterns = ["_build", "scenario_reference.md"]
html_theme = "alabaster"
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
