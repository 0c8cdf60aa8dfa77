"""The erodible bed of a closure run (``[bed] erodible = true``).

Per cycle, on the cycle's steady flow:

* the scour estimate: the clear-water equilibrium scour depth per cell (Laursen 1963; FHWA HEC-18's
  contraction scour), :func:`breachflow.hydro.morphology.equilibrium_scour` — the depth at which the
  Meyer-Peter–Müller / Exner evolution levels off when the flow's unit discharge is held and no sediment comes
  from upstream; the cycle reports the deepest scour and where, and writes the map ``scour_depth``;
* the bed change (``[bed] bed_change``, on by default): the Meyer-Peter–Müller / Exner evolution
  (:func:`breachflow.hydro.morphology.scour`) over the cycle's flow time — the operation time from the previous
  cycle's masses to this cycle's — lowers (or raises) the terrain the SWE re-solves on and the DEM's masses land
  on from the next cycle; at most ``bed_change_steps`` explicit steps (the flow time reached is reported).

The grain size is the bed's, or the stones of a bottom protection where it lies (``[bed] protection``, a region):
a protection does not move while its own threshold holds. Cells under the pile (obstacles, a raised bed or a
porous pile) do not erode. User documentation: ``docs/bed-and-forces.md``.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..hydro.morphology import equilibrium_scour, scour


def grain_map(bed, x, y) -> np.ndarray | float:
    """Grain size of the bed per cell (m): the protection's stones in its region, the bed's elsewhere."""
    d = float(bed.roughness.grain_size)
    if bed.protection is None:
        return d
    return bed.protection.grain_map(x, y, d)


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
                          grain_map(bed, x, y), np.broadcast_to(np.asarray(setup.domain.manning, float), z.shape))
    if s.max() > 0:
        j, i = np.unravel_index(int(np.argmax(s)), s.shape)
        depth_max, sx, sy = float(s[j, i]), float(x[i]), float(y[j])
    else:
        depth_max, sx, sy = 0.0, float("nan"), float("nan")
    da = xr.DataArray(s, dims=("y", "x"), attrs={"long_name": "clear-water equilibrium scour depth of the erodible "
                                                              "bed in this cycle's flow", "units": "m"})
    return da, depth_max, sx, sy


def cycle_bed_change(setup, snapshot, duration: float, fixed=None, *, open_edges: bool = True):
    """The terrain after *duration* (s) of the cycle's steady flow *snapshot* over the erodible bed
    (Meyer-Peter–Müller / Exner, :func:`~breachflow.hydro.morphology.scour`, the unit discharge and water level of
    each cell held); *fixed*: cells that do not erode (the pile). Returns ``(new terrain (y, x), info)`` with
    ``info`` the deepest lowering (m) and where, the largest rise (m), the flow time reached (s) and the steps;
    ``(None, {})`` when the bed does not change (not erodible, ``bed_change = false``, no flow time)."""
    bed = getattr(setup.dem, "bed", None)
    if bed is None or not bed.erodible or not bed.bed_change or not duration > 0:
        return None, {}
    dom = setup.domain
    z = np.asarray(dom.bed, float)
    x, y = np.asarray(dom.x, float), np.asarray(dom.y, float)
    depth = np.asarray(snapshot["depth"].values, float)
    still = np.asarray(dom.obstacle, bool).copy()
    if "obstacle" in snapshot:
        still |= np.asarray(snapshot["obstacle"].values, bool)
    if fixed is not None:
        still |= np.asarray(fixed, bool)
    depth = np.where(still, 0.0, depth)
    new, steps, t = scour(z, depth, np.asarray(snapshot["u"].values, float), np.asarray(snapshot["v"].values, float),
                          grain_map(bed, x, y), np.broadcast_to(np.asarray(dom.manning, float), z.shape),
                          float(duration), dx=dom.dx, dy=dom.dy, open_edges=open_edges,
                          max_steps=int(bed.bed_change_steps))
    new = np.where(still, z, new)
    drop = z - new
    j, i = np.unravel_index(int(np.argmax(drop)), drop.shape)
    info = {"bed_lowering": float(max(drop[j, i], 0.0)), "bed_lowering_x": float(x[i]) if drop[j, i] > 0 else np.nan,
            "bed_lowering_y": float(y[j]) if drop[j, i] > 0 else np.nan, "bed_rise": float(max(-drop.min(), 0.0)),
            "bed_change_time": float(t), "bed_change_duration": float(duration), "bed_change_steps": int(steps)}
    return new, info
