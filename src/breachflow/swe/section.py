"""The breach discharge through a channel section: one definition for the closure's reported value
(:func:`breachflow.cycle.criteria.section_discharge`) and the steady-state monitor of the ``swe`` solver
(:meth:`breachflow.swe.solver.SWESimulation.section_discharge`), and the window re-solve's
(:mod:`breachflow.hydro.resolve_region`)."""
from __future__ import annotations

import numpy as np


def channel_discharge(x, y, hv, open_wet, x_range, y0: float) -> float:
    """Discharge (m³/s) through the breach between ``x_range``, positive towards +y.

    At steady state continuity makes it the same through every cross-section of the breach channel: the
    grid rows, contiguous with the one nearest *y0*, whose cells just beyond both ends of ``x_range`` are
    closed (the levee or the breach walls: obstacle or dry, ``~open_wet``). Per row it is ``Σ h v Δx`` over
    the open wet cells (*hv*, m²/s, shaped (ny, nx)), but a cell-centre sum is the flux only where the bed
    is smooth: in a row through the pile (raised bed, porous pile) the momentum at cell centres beside a
    step is not the face flux (issue 16: cycle 2 of a nested closure read 53.3 m³/s on the levee line
    through the new masses, 32.6–36.0 on every other row of the opening). So the median over the channel's
    rows (the row nearest *y0* alone where no row is closed at both ends)."""
    x = np.asarray(x, float)
    yy = np.asarray(y, float)
    j0 = int(np.argmin(np.abs(yy - y0)))
    sel = (x >= x_range[0]) & (x <= x_range[1])
    dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
    inside = np.flatnonzero(sel)
    if inside.size == 0:
        return 0.0
    il, ir = inside[0] - 1, inside[-1] + 1
    if il < 0 or ir >= x.size:
        closed = np.zeros(yy.size, bool)
    else:
        closed = ~open_wet[:, il] & ~open_wet[:, ir]
    rows = [j0]
    if closed[j0]:
        lo = j0
        while lo > 0 and closed[lo - 1]:
            lo -= 1
        hi = j0
        while hi < yy.size - 1 and closed[hi + 1]:
            hi += 1
        rows = range(lo, hi + 1)
    q = [float(np.sum(hv[j, sel & open_wet[j]]) * dx) for j in rows]
    return float(np.median(q))


def open_wet(ds):
    """Cells of the snapshot *ds* that are wet (``wet``, else depth > 0) and not an obstacle."""
    wet = np.asarray(ds["wet"].values, bool) if "wet" in ds else np.asarray(ds["depth"].values, float) > 0.0
    if "obstacle" in ds:
        wet = wet & ~np.asarray(ds["obstacle"].values, bool)
    return wet


def snapshot_discharge(ds, x_range, y: float) -> float:
    """:func:`channel_discharge` of the snapshot *ds* (``depth``, ``v`` on ``x``, ``y``)."""
    hv = np.asarray(ds["depth"].values, float) * np.asarray(ds["v"].values, float)
    return channel_discharge(ds["x"].values, ds["y"].values, hv, open_wet(ds), x_range, y)
