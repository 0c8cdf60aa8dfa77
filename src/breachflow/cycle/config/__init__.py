"""Scenario-file sections of a closure run: ``[site]``, ``[hydro]``, ``[dem]``, ``[fluid]``,
``[placement]``, ``[criteria]``, ``[closure]`` (docs/theory.md, *Breach growth*, *Shallow-water equations*, *DEM contact*, *Fluid forces on a mass*, *The closure cycle*).

``[levee]`` and ``[breach]`` (length, depth, wall_slope, scour_depth) of the scenario override the site
preset's geometry; ``[flood]`` and ``[polder]``, when present, give the closure window the run is
judged against. :func:`closure_setup` turns a parsed scenario into a :class:`~.driver.ClosureSetup`.

Layout of the package (every public name is importable from here, where it is documented):
:mod:`~breachflow.cycle.config.site` (``[site]``, the preset scenes, the site CRS),
:mod:`~breachflow.cycle.config.hydro` (``[hydro]``), :mod:`~breachflow.cycle.config.dem` (``[dem]``,
``[fluid]``), :mod:`~breachflow.cycle.config.closure` (``[placement]``, ``[criteria]``, ``[closure]``) and
:mod:`~breachflow.cycle.config.setup` (:func:`closure_setup` and the solver wrappers it builds). Importing
this package registers the sections with :func:`~breachflow.scenario.config.register_section`.
"""
from __future__ import annotations

from .site import SITE_PRESETS, SiteSection, demo_breach
from .hydro import RESOLVE_MODES, SNAPSHOT_SOLVERS, HydroSection
from .dem import DemSection, FluidSection
from .closure import ClosureSection, CriteriaSection, PlacementSection
from .bed import BedSection, BedSettings
from .setup import closure_setup

__all__ = [
    "demo_breach", "SITE_PRESETS", "SiteSection", "RESOLVE_MODES", "SNAPSHOT_SOLVERS", "HydroSection", "DemSection",
    "FluidSection", "BedSection", "BedSettings", "PlacementSection", "CriteriaSection", "ClosureSection",
    "closure_setup",
]

# documented here, their public home (Sphinx reads a ``#:`` comment from the module that assigns the name)
#: warm re-solve of the ``swe`` solver: whole domain, or a region around the changed cells (hydro/resolve_region.py)
RESOLVE_MODES = RESOLVE_MODES

#: solvers that take ingested snapshot files
SNAPSHOT_SOLVERS = SNAPSHOT_SOLVERS
