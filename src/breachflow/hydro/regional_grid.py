"""Regional grids without a no-flow mask (ESRI ASCII grids, GDAL rasters): their dry cells read as
no-flow where the regional model must have blocked the flow (issue 13, nested solver; docs/theory.md, *Shallow-water equations*).

A mesh leaves an intact levee modelled as no-flow out as a hole; our own grids carry an ``obstacle``
mask. A raster export (RAS Mapper / GDAL ``.asc``, LISFLOOD-FP ``.wd``) has neither: the levee is
terrain with NODATA depth, like any dry ground. At steady state a finite-volume model cannot hold a
cell dry beside a wet cell whose water surface is above the dry cell's bed (water flows across that
face), nor beside such a cell: the water surface ``L`` of the wet cells spreads over the dry cells it
would flood (priority flood, 4 face neighbours)::

    L_c = max over face neighbours n of L_n with L_n > z_c + tol      (dry c; wet c: L_c = z_c + h_c)
    no_flow = dry & (L > z + tol),   tol = 1 cm

Those cells were no-flow in the regional model (the whole flooded-over part of the levee, not only
its first row: a local grid coarser than the regional one samples a one-cell ring with gaps). A local
model interpolated from the grid without this mask opens the levee's flood-side slope to the water and,
the crest being smoothed below the flood level by the interpolation, lets the whole levee overflow (a mean
``|Δ speed|`` of 12–14 % near the breach in the ESRI consistency check, ``tests/site/test_nested_esri.py``). Dry cells above
every such level stay ground (high ground, a crest above the flood). Applied by the nested solver to
grid snapshots that have no ``obstacle`` variable; a snapshot that is still filling (a wetting front
running downhill) would be read as walled: give the regional model's steady state.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..field.snapshot import DRY_DEPTH, is_mesh

#: a dry cell this far (m) or more below a wet neighbour's water surface is a no-flow cell
NO_FLOW_TOLERANCE = 0.01


def infer_no_flow(grid: xr.Dataset, tolerance: float = NO_FLOW_TOLERANCE) -> np.ndarray:
    """The ``(ny, nx)`` mask of dry cells that the wet cells' water surface would flood by more than
    *tolerance* (module docstring: priority flood over face neighbours)."""
    bed = np.asarray(grid["bed_elevation"].values, float)
    h = np.asarray(grid["depth"].values, float)
    wet = np.isfinite(h) & (h > DRY_DEPTH)
    level = np.where(wet, bed + np.where(wet, h, 0.0), -np.inf)
    for _ in range(level.size):
        p = np.pad(level, 1, constant_values=-np.inf)
        nbs = (p[:-2, 1:-1], p[2:, 1:-1], p[1:-1, :-2], p[1:-1, 2:])
        reach = np.maximum.reduce([np.where(n > bed + tolerance, n, -np.inf) for n in nbs])
        new = np.where(wet, level, np.maximum(level, reach))
        if np.array_equal(new, level):
            break
        level = new
    return ~wet & (level > bed + tolerance)


def with_no_flow(regional: xr.Dataset) -> xr.Dataset:
    """*regional* with an ``obstacle`` mask from :func:`infer_no_flow` when it is a grid without one
    (unchanged otherwise: meshes, grids with a mask, grids with no such dry cell)."""
    if is_mesh(regional) or "obstacle" in regional or "depth" not in regional or regional["depth"].dims != ("y", "x"):
        return regional
    mask = infer_no_flow(regional)
    if not mask.any():
        return regional
    out = regional.copy()
    out["obstacle"] = (("y", "x"), mask.astype("i1"),
                       {"long_name": "no-flow cell mask inferred from dry cells below the wet cells' water surface",
                        "units": "1", "flag_values": np.array([0, 1], dtype="i1"), "flag_meanings": "open blocked"})
    out.attrs["obstacle_inferred"] = (f"{int(mask.sum())} dry cells the wet cells' water surface would flood by more than "
                                      f"{NO_FLOW_TOLERANCE:g} m read as no-flow (breachflow.hydro.regional_grid)")
    return out
