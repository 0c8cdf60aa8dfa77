"""Remap resting masses into the hydrodynamic model (SPEC §7 step 10, report Fig 4.5).

Two modes, chosen by name:

* ``"no_flow"`` (the report): every cell whose centre lies inside the plan footprint of a resting
  sphere becomes an impervious obstacle cell.
* ``"raised_bed"``: the pile raises the bed to the top of the spheres above each cell centre,
  ``z_top = z_c + sqrt(r² − d²)`` (d the plan distance); where that top reaches the water surface
  the cell is blocked (an emergent pile), otherwise water flows over the raised bed.
"""
from __future__ import annotations

import numba
import numpy as np

from ..errors import InputError

REMAP_MODES = ("no_flow", "raised_bed")


@numba.njit(cache=True)
def pile_top(x, y, bed, pos, radius, use):
    """Per cell: the highest sphere top above the cell centre (−inf where none covers it)."""
    ny, nx = bed.shape
    top = np.full((ny, nx), -np.inf)
    x0 = x[0]
    y0 = y[0]
    dx = x[1] - x[0] if nx > 1 else 1.0
    dy = y[1] - y[0] if ny > 1 else 1.0
    for p in range(pos.shape[0]):
        if not use[p]:
            continue
        r = radius[p]
        i0 = max(int(np.ceil((pos[p, 0] - r - x0) / dx)), 0)
        i1 = min(int(np.floor((pos[p, 0] + r - x0) / dx)), nx - 1)
        j0 = max(int(np.ceil((pos[p, 1] - r - y0) / dy)), 0)
        j1 = min(int(np.floor((pos[p, 1] + r - y0) / dy)), ny - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                d2 = (x[i] - pos[p, 0]) ** 2 + (y[j] - pos[p, 1]) ** 2
                if d2 <= r * r:
                    z = pos[p, 2] + np.sqrt(r * r - d2)
                    if z > top[j, i]:
                        top[j, i] = z
    return top


def remap(x, y, bed, water_surface, pos, radius, resting, mode: str = "no_flow"):
    """Return ``(obstacle, new_bed)`` for the resting particles (arrays shaped like *bed*).

    *x*, *y* cell-centre coordinates (uniformly spaced), *water_surface* the current water-surface
    elevation (m) per cell, used by ``raised_bed`` to decide emergence.
    """
    if mode not in REMAP_MODES:
        raise InputError(f"remap mode {mode!r} unknown; use one of {REMAP_MODES}")
    x = np.ascontiguousarray(x, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    bed = np.asarray(bed, dtype=float)
    top = pile_top(x, y, bed, np.ascontiguousarray(pos, dtype=float).reshape(-1, 3),
                   np.ascontiguousarray(radius, dtype=float), np.ascontiguousarray(resting, dtype=np.bool_))
    covered = np.isfinite(top)
    if mode == "no_flow":
        return covered, bed.copy()
    raised = np.where(covered & (top > bed), top, bed)
    emergent = covered & (top >= np.asarray(water_surface, float))
    return emergent, raised
