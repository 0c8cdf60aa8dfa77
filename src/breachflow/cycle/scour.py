"""The per-cycle scour estimate of an erodible bed (``[bed] erodible = true``), a documented first step: on the
cycle's steady flow, the clear-water equilibrium scour depth per cell (Laursen 1963; FHWA HEC-18's contraction
scour), :func:`breachflow.hydro.morphology.equilibrium_scour` — the depth at which the Meyer-Peter–Müller /
Exner evolution (:func:`breachflow.hydro.morphology.scour`) levels off when the flow's unit discharge is held and
no sediment comes from upstream — with the bed's grain size (a bottom protection: its stones). Where the flow is
fastest — the toe and the breach heads — the bed scours unless its grains hold; the cycle reports the deepest
scour and where, and writes the map ``scour_depth``. The terrain the SWE and the DEM see is not lowered
(docs/bed-and-forces.md)."""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..hydro.morphology import equilibrium_scour


def cycle_scour(setup, snapshot):
    """``(scour map DataArray (y, x) or None, max depth (m), x, y)`` of the cycle's *snapshot*; None and zeros when
    the bed is not erodible."""
    bed = getattr(setup.dem, "bed", None)
    if bed is None or not bed.erodible:
        return None, 0.0, float("nan"), float("nan")
    x = np.asarray(snapshot["x"].values, float)
    y = np.asarray(snapshot["y"].values, float)
    z = np.asarray(snapshot["bed_elevation"].values, float)
    obstacle = np.asarray(snapshot["obstacle"].values, bool) if "obstacle" in snapshot else np.zeros(z.shape, bool)
    depth = np.where(obstacle, 0.0, np.asarray(snapshot["depth"].values, float))
    s = equilibrium_scour(depth, np.asarray(snapshot["u"].values, float), np.asarray(snapshot["v"].values, float),
                          bed.roughness.grain_size, np.broadcast_to(np.asarray(setup.domain.manning, float), z.shape))
    if s.max() > 0:
        j, i = np.unravel_index(int(np.argmax(s)), s.shape)
        depth_max, sx, sy = float(s[j, i]), float(x[i]), float(y[j])
    else:
        depth_max, sx, sy = 0.0, float("nan"), float("nan")
    da = xr.DataArray(s, dims=("y", "x"), attrs={"long_name": "clear-water equilibrium scour depth of the erodible "
                                                              "bed in this cycle's flow", "units": "m"})
    return da, depth_max, sx, sy
