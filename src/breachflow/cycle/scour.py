"""The per-cycle scour estimate of an erodible bed (``[bed] erodible = true``): Meyer-Peter–Müller bed load and
Exner (:func:`breachflow.hydro.morphology.scour`) on the cycle's steady flow for ``[bed] scour_time``, with the
bed's grain size (a bottom protection: its stones). Where the flow is fastest — the toe and the breach heads —
the bed scours unless its grains hold; the cycle reports the deepest scour and where, and writes the map
``scour_depth``. A first step: the terrain the SWE and the DEM see is not lowered (docs/bed-and-forces.md)."""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..hydro.morphology import scour, scour_summary


def cycle_scour(setup, snapshot):
    """``(scour map DataArray (y, x) or None, max depth (m), x, y)`` of the cycle's *snapshot*; None and zeros when
    the bed is not erodible."""
    bed = getattr(setup.dem, "bed", None)
    if bed is None or not bed.erodible:
        return None, 0.0, float("nan"), float("nan")
    x = np.asarray(snapshot["x"].values, float)
    y = np.asarray(snapshot["y"].values, float)
    z = np.asarray(snapshot["bed_elevation"].values, float)
    dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
    dy = abs(y[1] - y[0]) if y.size > 1 else 1.0
    obstacle = np.asarray(snapshot["obstacle"].values, bool) if "obstacle" in snapshot else np.zeros(z.shape, bool)
    depth = np.where(obstacle, 0.0, np.asarray(snapshot["depth"].values, float))
    new, _ = scour(z, depth, np.asarray(snapshot["u"].values, float), np.asarray(snapshot["v"].values, float),
                   bed.roughness.grain_size, np.broadcast_to(np.asarray(setup.domain.manning, float), z.shape),
                   bed.scour_time, dx=dx, dy=dy, porosity=bed.porosity)
    s = np.maximum(z - new, 0.0)
    depth_max, sx, sy = scour_summary(x, y, z, new)
    da = xr.DataArray(s, dims=("y", "x"), attrs={"long_name": "scour depth of the erodible bed after scour_time",
                                                  "units": "m"})
    return da, depth_max, sx, sy
