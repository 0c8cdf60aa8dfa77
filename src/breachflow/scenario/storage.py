"""A polder's stage–storage curve from its terrain (``[polder] storage = "terrain"``).

The water that enters through the breach spreads from the breach's landside cell (the *seed*). It runs
downhill freely, and it climbs into a cell only when the polder's level stands above that cell's ground.
A cell ``c`` therefore starts to store water at the level

    E(c) = max(bed(c), R(c)),   R(c) = min over the paths seed -> c of the max over their steps of the
                                       step's cost: 0 (-inf) for a step down, bed(b) for a step up to b,

(the lowest level at which the flood spreading from the seed reaches ``c``; a priority flood, Dijkstra's
algorithm with the max in place of the sum, over the four neighbours of each cell). A hollow behind a ridge
that the breach water cannot run down into gets its water only once the level tops the ridge; below that
it is not part of the polder's storage. The volume below a level ``z`` is then

    V(z) = A_cell * sum over the cells with E(c) < z of (z - bed(c))

(cells flat at their centre's elevation), exact for that terrain at every level; the curve is tabulated
every ``level_step`` from the lowest reachable ground to the highest ground of the region and continued
above with the region's full plan area (:class:`~breachflow.scenario.polder.Polder`).

Only the cells inside the protected *region* count: by default the protected side of the levee's
centreline in the flow model, or a box ``[x0, x1, y0, y1]`` / a polygon ``[[x, y], ...]`` given in
``[polder] region`` (coordinates of the terrain: the flow model's grid, or the GeoTIFF's CRS).

Why not a library: the depression-filling routines of terrain packages (e.g. priority-flood ``fill``
in richdem, morphological reconstruction in scikit-image) fill every depression up to its spill level
from the domain's edge, which is the opposite question (a hollow is counted whether or not the breach
water reaches it); the spread from one seed with free downhill steps is the few lines of :func:`reach_levels`.
"""
from __future__ import annotations

import heapq

import numpy as np

from ..errors import InputError

try:  # numba kernel (plain arrays); a pure-Python fallback of the same code otherwise
    from numba import njit
except ImportError:  # pragma: no cover
    def njit(*a, **k):
        return (lambda f: f) if not a or not callable(a[0]) else a[0]


@njit(cache=True)
def _reach_levels_kernel(bed, valid, si, sj):  # pragma: no cover - compiled
    ny, nx = bed.shape
    reach = np.full((ny, nx), np.inf)
    done = np.zeros((ny, nx), np.bool_)
    reach[si, sj] = -np.inf
    heap = [(-np.inf, si, sj)]
    di = (1, -1, 0, 0)
    dj = (0, 0, 1, -1)
    while len(heap) > 0:
        r, i, j = heapq.heappop(heap)
        if done[i, j]:
            continue
        done[i, j] = True
        for k in range(4):
            a, b = i + di[k], j + dj[k]
            if a < 0 or a >= ny or b < 0 or b >= nx or not valid[a, b] or done[a, b]:
                continue
            step = -np.inf if bed[a, b] < bed[i, j] else bed[a, b]
            cand = max(r, step)
            if cand < reach[a, b]:
                reach[a, b] = cand
                heapq.heappush(heap, (cand, a, b))
    return reach


def reach_levels(bed, seed, valid=None) -> np.ndarray:
    """``E(c) = max(bed(c), R(c))`` of every cell (m): the polder level at which the water spreading from the
    *seed* cell ``(row, column)`` starts to stand in it (inf for cells outside *valid* or never reached)."""
    bed = np.ascontiguousarray(bed, float)
    valid = np.ones(bed.shape, bool) if valid is None else np.ascontiguousarray(valid, bool)
    si, sj = int(seed[0]), int(seed[1])
    if not valid[si, sj]:
        raise InputError("polder storage: the breach's landside cell lies outside the polder region")
    reach = _reach_levels_kernel(bed, valid, si, sj)
    return np.where(np.isfinite(reach) | (reach == -np.inf), np.maximum(bed, reach), np.inf)


def region_mask(x, y, region) -> np.ndarray:
    """Cells (centres ``x`` along columns, ``y`` along rows) inside *region*: None (all), a box
    ``[x0, x1, y0, y1]`` or a polygon ``[[x, y], ...]`` (matplotlib's point-in-polygon test)."""
    X, Y = np.meshgrid(np.asarray(x, float), np.asarray(y, float))
    if region is None:
        return np.ones(X.shape, bool)
    arr = np.asarray(region, float)
    if arr.ndim == 1 and arr.size == 4:
        x0, x1, y0, y1 = arr
        return (X >= min(x0, x1)) & (X <= max(x0, x1)) & (Y >= min(y0, y1)) & (Y <= max(y0, y1))
    from matplotlib.path import Path as MplPath

    inside = MplPath(arr).contains_points(np.column_stack([X.ravel(), Y.ravel()]))
    return inside.reshape(X.shape)


def terrain_storage_curve(bed, x, y, seed_xy, *, region=None, level_step: float = 0.1, mask=None):
    """``(levels m, volumes m³)``: the stage–storage curve of the terrain *bed* (rows along *y*, columns
    along *x*, cell centres, uniform spacing) below each level, counting only the cells inside *region*
    (see :func:`region_mask`; *mask* a boolean array instead) that the water from the cell nearest to
    *seed_xy* reaches (:func:`reach_levels`). Levels every *level_step* from the lowest reached ground to
    the highest ground of the region (at least two)."""
    bed = np.asarray(bed, float)
    x, y = np.asarray(x, float), np.asarray(y, float)
    if bed.shape != (y.size, x.size):
        raise InputError(f"polder storage: terrain of shape {bed.shape} does not match {y.size} x {x.size} cell centres")
    if not (np.isfinite(level_step) and level_step > 0):
        raise InputError(f"polder storage: level_step must be > 0 m, got {level_step!r}")
    cell = abs(float(x[1] - x[0])) * abs(float(y[1] - y[0])) if x.size > 1 and y.size > 1 else 0.0
    if not cell > 0:
        raise InputError("polder storage: the terrain needs at least two cells along each axis")
    valid = (region_mask(x, y, region) if mask is None else np.asarray(mask, bool)) & np.isfinite(bed)
    if not valid.any():
        raise InputError(f"polder storage: no terrain cell lies inside the region {region!r}")
    sj = int(np.argmin(np.abs(x - seed_xy[0])))
    si = int(np.argmin(np.abs(y - seed_xy[1])))
    e = reach_levels(np.where(valid, bed, np.inf), (si, sj), valid)
    ok = np.isfinite(e)
    ev, zb = e[ok], bed[ok]
    order = np.argsort(ev, kind="stable")
    ev, zb = ev[order], zb[order]
    csum = np.concatenate([[0.0], np.cumsum(zb)])
    lo, hi = float(zb.min()), float(max(zb.max(), ev.max()))
    n = max(int(np.ceil((hi - lo) / level_step)), 1)
    levels = lo + level_step * np.arange(n + 2)  # one step above the highest ground: the full plan area
    k = np.searchsorted(ev, levels, side="left")  # cells with E < z
    volumes = cell * (levels * k - csum[k])
    return levels, np.maximum.accumulate(np.maximum(volumes, 0.0))
