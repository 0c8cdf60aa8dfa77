"""The pile's crest along a line, read from the masses themselves (SI).

A point ``s`` of the line (the gap line of a placement, or the breach section along the levee) lies under the
highest top ``z_i + r_i`` of the units whose silhouette covers it: a unit of radius ``r_i`` whose centre
projects onto the line at ``s_i`` covers ``|s - s_i| <= r_i``. The crest there is that top, or the ground
where the ground is higher::

    crest(s) = max(ground(s), max{z_i + r_i : |s - s_i| <= r_i})

It is read every :data:`CREST_STEP` m, the same reading whatever the flow grid's cells: a crest taken as the
highest pile top of each grid cell hides every notch narrower than a cell, so a coarse grid sees a closed crest
where a fine one sees openings (docs/verdict-check.md,
*The crest from the units, and rock at the breach heads*).

A stretch where the crest stays below a water level is an *opening*. One narrower than a unit is a void of the
crest between units that stand above the water: no further unit fits into it.
"""
from __future__ import annotations

import numpy as np

#: step (m) at which the crest is read along the line
CREST_STEP = 0.05


def stations(length: float, step: float = CREST_STEP) -> np.ndarray:
    """Points 0 … *length* (m) along a line, evenly spaced at most *step* apart (at least two)."""
    n = max(int(np.ceil(float(length) / step)), 1)
    return np.linspace(0.0, float(length), n + 1)


def crest_profile(s, ground, along, top, half_width) -> np.ndarray:
    """``crest(s) = max(ground(s), max{top_i : |s - along_i| <= half_width_i})`` (module docstring) at the
    increasing stations *s* (m), *ground* their ground elevation, and per unit its position *along* the line,
    its *top* elevation and the *half_width* of its silhouette (its radius)."""
    s = np.asarray(s, float)
    crest = np.array(ground, float, copy=True)
    along, top, half = (np.asarray(a, float).ravel() for a in (along, top, half_width))
    lo = np.searchsorted(s, along - half, side="left")
    hi = np.searchsorted(s, along + half, side="right")
    for a, b, t in zip(lo, hi, top):
        if b > a and t > crest[a:b].min():
            np.maximum(crest[a:b], t, out=crest[a:b])
    return crest


def openings(s, crest, level: float, step: float = CREST_STEP) -> list[tuple[float, float]]:
    """The stretches ``(s_start, s_end)`` (m) where *crest* stays below *level*: runs of neighbouring stations
    (*s* spaced *step*) below it, each widened by half a step at both ends (a lone station is one step wide)."""
    s = np.asarray(s, float)
    below = np.flatnonzero(np.asarray(crest, float) < level)
    if below.size == 0:
        return []
    cut = np.flatnonzero((np.diff(below) > 1) | (np.diff(s[below]) > 1.5 * step)) + 1
    return [(float(s[r[0]]) - 0.5 * step, float(s[r[-1]]) + 0.5 * step) for r in np.split(below, cut)]
