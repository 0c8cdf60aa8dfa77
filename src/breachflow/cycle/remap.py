"""Remap resting masses into the hydrodynamic model (docs/theory.md, *The closure cycle*, report Fig 4.5).

How the pile enters ``no_flow`` and ``raised_bed`` (``[closure] pile_sampling``):

* ``"centre"`` (the default, the report's "simplest interpolation"): the pile top above each cell centre,
  ``z_top = z_c + sqrt(r² − d²)`` (d the plan distance; ``pile_top``). A cell between two spheres keeps
  the bare floor, and a sphere settling by a few cm can drop a cell by metres (0.57 m for 3 cm with
  0.5 m spheres on 1 m cells; the breach discharge of the default scene rose 12–17 % when one 2 m sphere
  settled 1–2 cm sideways and down, ``tests/cycle/test_pile_cells.py``; issue 16).
* ``"cell_average"``: cell quantities of the pile's top surface ``T(x, y) = max_p (z_p + sqrt(r_p² − d_p²))``
  (−inf where no sphere covers the point), sampled at ``sub × sub`` sub-points of each cell
  (:func:`pile_cells`, the sub-points of ``pile_columns``; spacing ≤ r / 8, :func:`subpoints`):

  - the **lift**, the cell average of the pile above the bed, ``Δb = (1/A) ∫_cell max(T − b, 0) dA``: a
    finite-volume cell holds the cell average of the bed (a piecewise constant bed, as in the hydrostatic
    reconstruction of Audusse et al. 2004, SIAM J. Sci. Comput. 25:2050; GeoClaw sets each cell's
    topography from the cell integral of the topography). ``Σ Δb dx dy`` is the volume between the bed and
    the pile's top surface (voids under the top count as solid: an impervious bed cannot hold them; the
    porous mode does), and a sphere moved by δ changes ``Σ |Δb| dx dy`` by at most δ times the total
    variation of T;
  - the **emergence level**, the area median of T over the cell: the level at or below which the pile
    stands over at least half of the cell (−inf where it covers less than half).

Modes, chosen by name:

* ``"no_flow"`` (the report): every covered cell becomes an impervious obstacle cell (``centre``: its centre
  lies in a sphere's plan footprint; ``cell_average``: at least half of it does).
* ``"raised_bed"``: the bed rises to the pile (``centre``: the top above the centre; ``cell_average``: by
  the lift); a cell where the pile reaches the water surface (``centre``: at its centre; ``cell_average``:
  over at least half of it, the emergence level) is blocked, otherwise water flows over the raised bed.
  The closure cycle passes the flood level as that surface (the highest a steady flow fed from the flood
  side backs up to; the previous surface, raised by the pile itself, let blocked cells open again: issue 16).
* ``"porous"``: the pile stays in the water column: per cell its height above the bed (the highest
  sphere top over k × k sub-points of the cell; a maximum, so it shares the centre sample's jumps: up to
  1.21 m when one of four 2 m spheres on 1 m cells moves 3 cm — the cell average instead left the default
  run "not closable" after 15 cycles, issue 16), the column cut into :data:`PILE_LAYERS` equal layers, each
  with its porosity ``n = 1 - V_solid / V_pile`` from the DEM packing (``V_solid`` the sphere volume inside
  the layer, by the chord lengths over the sub-points; ``V_pile = height dx dy / layers``), both summed
  over the pile cells within one stone diameter
  (a representative volume: a cell smaller than a stone is either almost solid or almost void), and its
  volume-weighted stone diameter give a
  :class:`~breachflow.swe.porous.PorousPile`; the ``swe`` solver makes the flow pass through it with
  Forchheimer resistance and over its crest freely (:mod:`breachflow.swe.porous`). No cell is blocked.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import InputError

REMAP_MODES = ("no_flow", "raised_bed", "porous")
#: how the resting pile enters ``no_flow`` / ``raised_bed`` (``[closure] pile_sampling``)
PILE_SAMPLINGS = ("centre", "cell_average")


@numba.njit(cache=True)
def pile_top_box(x, y, pos, radius, use, i_lo, i_hi, j_lo, j_hi, top):
    """Raise *top* (ny, nx) to the sphere tops above the cell centres of the index box
    ``[j_lo..j_hi] x [i_lo..i_hi]`` (cells outside it are left alone)."""
    nx = x.shape[0]
    ny = y.shape[0]
    x0 = x[0]
    y0 = y[0]
    dx = x[1] - x[0] if nx > 1 else 1.0
    dy = y[1] - y[0] if ny > 1 else 1.0
    for p in range(pos.shape[0]):
        if not use[p]:
            continue
        r = radius[p]
        i0 = max(int(np.ceil((pos[p, 0] - r - x0) / dx)), i_lo)
        i1 = min(int(np.floor((pos[p, 0] + r - x0) / dx)), i_hi)
        j0 = max(int(np.ceil((pos[p, 1] - r - y0) / dy)), j_lo)
        j1 = min(int(np.floor((pos[p, 1] + r - y0) / dy)), j_hi)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                d2 = (x[i] - pos[p, 0]) ** 2 + (y[j] - pos[p, 1]) ** 2
                if d2 <= r * r:
                    z = pos[p, 2] + np.sqrt(r * r - d2)
                    if z > top[j, i]:
                        top[j, i] = z


@numba.njit(cache=True)
def pile_top(x, y, bed, pos, radius, use):
    """Per cell: the highest sphere top above the cell centre (−inf where none covers it)."""
    ny, nx = bed.shape
    top = np.full((ny, nx), -np.inf)
    pile_top_box(x, y, pos, radius, use, 0, nx - 1, 0, ny - 1, top)
    return top


#: sub-points per cell side for the cell quantities of the pile (``no_flow``, ``raised_bed``), at least
SUB = 32
#: layers of the porous pile's column (:func:`porous_pile`, :mod:`breachflow.swe.porous`)
PILE_LAYERS = 4


def subpoints(dx: float, dy: float, r_min: float, cap: int = 64) -> int:
    """Sub-points per cell side so that their spacing is at most ``r_min / 8`` (at least ``SUB``, at most
    *cap*): the midpoint rule over a sphere's footprint then errs by < 1 % in volume (the error goes as
    ``(s / r)^1.5``: 0.6 % at r / 8, 0.2 % at r / 16; ``tests/cycle/test_pile_cells.py``)."""
    if not r_min > 0:
        return SUB
    return int(min(max(SUB, math.ceil(8.0 * max(abs(dx), abs(dy)) / r_min)), cap))


@numba.njit(cache=True, inline="always")
def _sub_point(c, k, sub, h):
    """Coordinate of sub-point *k* (0 … sub − 1) of the cell centred at *c* of width *h*."""
    return c + ((k + 0.5) / sub - 0.5) * h


@numba.njit(cache=True)
def pile_cells_box(x, y, bed, pos, radius, use, sub, i_lo, i_hi, j_lo, j_hi, lift, level):
    """The cell quantities of the pile (module docstring) on the index box ``[j_lo..j_hi] x [i_lo..i_hi]``:
    *lift* the cell average of ``max(T − bed, 0)`` and *level* the area median of T (−inf where the pile
    covers less than half of the cell), T the highest sphere top over ``sub × sub`` sub-points."""
    nx = x.shape[0]
    ny = y.shape[0]
    dx = x[1] - x[0] if nx > 1 else 1.0
    dy = y[1] - y[0] if ny > 1 else 1.0
    ni = i_hi - i_lo + 1
    nj = j_hi - j_lo + 1
    if ni <= 0 or nj <= 0:
        return
    sx = dx / sub
    sy = dy / sub
    gx0 = _sub_point(x[i_lo], 0, sub, dx)  # first sub-point of the box
    gy0 = _sub_point(y[j_lo], 0, sub, dy)
    tops = np.full((nj * sub, ni * sub), -np.inf)
    for p in range(pos.shape[0]):
        if not use[p]:
            continue
        r = radius[p]
        # one sub-point of margin against rounding: the distance test decides
        k0 = max(int(np.floor((pos[p, 0] - r - gx0) / sx)), 0)
        k1 = min(int(np.ceil((pos[p, 0] + r - gx0) / sx)), ni * sub - 1)
        l0 = max(int(np.floor((pos[p, 1] - r - gy0) / sy)), 0)
        l1 = min(int(np.ceil((pos[p, 1] + r - gy0) / sy)), nj * sub - 1)
        for l in range(l0, l1 + 1):
            jj = l // sub
            py = _sub_point(y[j_lo + jj], l - jj * sub, sub, dy)
            for k in range(k0, k1 + 1):
                ii = k // sub
                px = _sub_point(x[i_lo + ii], k - ii * sub, sub, dx)
                d2 = (px - pos[p, 0]) ** 2 + (py - pos[p, 1]) ** 2
                if d2 < r * r:
                    z = pos[p, 2] + np.sqrt(r * r - d2)
                    if z > tops[l, k]:
                        tops[l, k] = z
    n = sub * sub
    half = (n + 1) // 2  # the pile must stand over at least half of the sub-points
    vals = np.empty(n)
    for jj in range(nj):
        for ii in range(ni):
            b = bed[j_lo + jj, i_lo + ii]
            acc = 0.0
            m = 0
            for l in range(sub):
                for k in range(sub):
                    t = tops[jj * sub + l, ii * sub + k]
                    vals[m] = t
                    m += 1
                    if t > b:
                        acc += t - b
            lift[j_lo + jj, i_lo + ii] = acc / n
            vals.sort()
            level[j_lo + jj, i_lo + ii] = vals[n - half]  # the half-th highest


def _contiguous(x, y, bed, pos, radius, use):
    """The kernels' inputs as C-contiguous float arrays (positions (N, 3)) and a bool mask."""
    return (np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float),
            np.ascontiguousarray(bed, dtype=float), np.ascontiguousarray(pos, dtype=float).reshape(-1, 3),
            np.ascontiguousarray(radius, dtype=float), np.ascontiguousarray(use, dtype=np.bool_))


def pile_cells(x, y, bed, pos, radius, use, sub: int = SUB):
    """``(lift, level)`` of the spheres *use* over the whole grid (module docstring)."""
    x, y, bed, pos, radius, use = _contiguous(x, y, bed, pos, radius, use)
    lift = np.zeros(bed.shape)
    level = np.full(bed.shape, -np.inf)
    box = _footprint_box(x, y, pos[use[:pos.shape[0]]], radius[use[:pos.shape[0]]])
    if box is not None:
        i0, i1, j0, j1 = box
        pile_cells_box(x, y, bed, pos, radius, use, int(sub), i0, i1, j0, j1, lift, level)
    return lift, level


def _footprint_box(x, y, centres, r):
    """The index box ``(i0, i1, j0, j1)`` of the cells the plan discs (*centres*, *r*) can reach (None: none)."""
    if centres.shape[0] == 0:
        return None
    dx = x[1] - x[0] if x.size > 1 else 1.0
    dy = y[1] - y[0] if y.size > 1 else 1.0
    i0 = max(int(np.floor((np.min(centres[:, 0] - r) - x[0]) / dx)), 0)
    i1 = min(int(np.ceil((np.max(centres[:, 0] + r) - x[0]) / dx)), x.size - 1)
    j0 = max(int(np.floor((np.min(centres[:, 1] - r) - y[0]) / dy)), 0)
    j1 = min(int(np.ceil((np.max(centres[:, 1] + r) - y[0]) / dy)), y.size - 1)
    return None if i0 > i1 or j0 > j1 else (i0, i1, j0, j1)


def remap(x, y, bed, water_surface, pos, radius, resting, mode: str = "no_flow", sampling: str = "centre",
          sub: int = SUB):
    """Return ``(obstacle, new_bed)`` for the resting particles (arrays shaped like *bed*).

    *x*, *y* cell-centre coordinates (uniformly spaced), *water_surface* the current water-surface
    elevation (m) per cell, used by ``raised_bed`` to decide emergence; *sampling* ``"centre"`` (the sphere
    top above each cell centre, :func:`remap_top`) or ``"cell_average"`` (:func:`pile_cells`,
    :func:`remap_cells`; module docstring).
    """
    _check_mode(mode)
    _check_sampling(sampling)
    if sampling == "cell_average":
        lift, level = pile_cells(x, y, bed, pos, radius, resting, sub)
        return remap_cells(lift, level, bed, water_surface, mode)
    x, y, bed, pos, radius, resting = _contiguous(x, y, bed, pos, radius, resting)
    return remap_top(pile_top(x, y, bed, pos, radius, resting), bed, water_surface, mode)


def _check_mode(mode):
    if mode not in REMAP_MODES:
        raise InputError(f"remap mode {mode!r} unknown; use one of {REMAP_MODES}")


def _check_sampling(sampling):
    if sampling not in PILE_SAMPLINGS:
        raise InputError(f"pile sampling {sampling!r} unknown; use one of {PILE_SAMPLINGS}")


class IncrementalPileTop:
    """The pile top of ``pile_top`` and the cell quantities of :func:`pile_cells` (``lift``, ``level``),
    kept up to date cycle after cycle at the cost of the masses that changed (moved, stopped or started
    resting, or were added), not of the whole pile.

    ``update(pos, radius, resting)`` returns the same grid as ``pile_top`` over all masses and leaves
    ``lift`` and ``level`` equal to ``pile_cells`` over all masses: the cells under the old and new
    footprints of the changed masses are recomputed from every resting mass that reaches them (maxima
    per point, so the result is exact, whatever the order).
    """

    def __init__(self, x, y, bed, sub: int = SUB, cells: bool = True):
        self.x = np.ascontiguousarray(x, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self.bed = np.ascontiguousarray(bed, dtype=float)
        self.sub = int(sub)
        self.cells = bool(cells)  # keep lift and level too (False: the centre top only)
        self.top = None
        self.lift = np.zeros(self.bed.shape)
        self.level = np.full(self.bed.shape, -np.inf)
        self.pos = np.zeros((0, 3))
        self.resting = np.zeros(0, bool)
        #: masses whose footprint was (re)computed by the last update (for work accounting)
        self.last_changed = 0

    def update(self, pos, radius, resting) -> np.ndarray:
        pos = np.ascontiguousarray(pos, dtype=float).reshape(-1, 3)
        radius = np.ascontiguousarray(radius, dtype=float)
        resting = np.ascontiguousarray(resting, dtype=np.bool_)
        if self.top is None:
            self.top = pile_top(self.x, self.y, self.bed, pos, radius, resting)
            if self.cells:
                self.lift, self.level = pile_cells(self.x, self.y, self.bed, pos, radius, resting, self.sub)
            self.last_changed = int(resting.sum())
        else:
            n_old = self.pos.shape[0]
            old_rest = self.resting
            moved = np.any(pos[:n_old] != self.pos, axis=1) & (old_rest | resting[:n_old])
            changed = np.flatnonzero(moved | (old_rest != resting[:n_old]))
            added = n_old + np.flatnonzero(resting[n_old:])
            self.last_changed = int(changed.size + added.size)
            if self.last_changed:
                # footprints (old and new) of the changed masses, as an index box on the grid
                ids = np.concatenate([changed, added])
                centres = np.concatenate([self.pos[changed], pos[ids]])
                r = np.concatenate([radius[changed], radius[ids]])
                box = _footprint_box(self.x, self.y, centres, r)
                if box is not None:
                    self._recompute(box, pos, radius, resting)
        self.pos = pos.copy()
        self.resting = resting.copy()
        return self.top

    def _recompute(self, box, pos, radius, resting):
        i0, i1, j0, j1 = box
        # every resting mass that may reach the box (one cell of margin against rounding)
        mx = self.x[1] - self.x[0] if self.x.size > 1 else 1.0
        my = self.y[1] - self.y[0] if self.y.size > 1 else 1.0
        reach = (resting & (pos[:, 0] + radius >= self.x[i0] - mx) & (pos[:, 0] - radius <= self.x[i1] + mx)
                 & (pos[:, 1] + radius >= self.y[j0] - my) & (pos[:, 1] - radius <= self.y[j1] + my))
        sel = np.flatnonzero(reach)
        p, r, use = np.ascontiguousarray(pos[sel]), np.ascontiguousarray(radius[sel]), np.ones(sel.size, np.bool_)
        self.top[j0:j1 + 1, i0:i1 + 1] = -np.inf
        pile_top_box(self.x, self.y, p, r, use, i0, i1, j0, j1, self.top)
        if self.cells:
            pile_cells_box(self.x, self.y, self.bed, p, r, use, self.sub, i0, i1, j0, j1, self.lift, self.level)


def remap_top(top, bed, water_surface, mode: str = "no_flow"):
    """``(obstacle, new_bed)`` from the centre pile top (``pile_top``, ``sampling = "centre"``): covered
    cells (``no_flow``), the bed raised to the top and blocked where it reaches the surface (``raised_bed``)."""
    _check_mode(mode)
    bed = np.asarray(bed, dtype=float)
    covered = np.isfinite(top)
    if mode == "porous":
        return np.zeros(bed.shape, bool), bed.copy()
    if mode == "no_flow":
        return covered, bed.copy()
    raised = np.where(covered & (top > bed), top, bed)
    emergent = covered & (top >= np.asarray(water_surface, float))
    return emergent, raised


def remap_cells(lift, level, bed, water_surface, mode: str = "no_flow"):
    """``(obstacle, new_bed)`` from the pile's cell quantities (:func:`pile_cells`); see :func:`remap`."""
    _check_mode(mode)
    bed = np.asarray(bed, dtype=float)
    if mode == "porous":
        return np.zeros(bed.shape, bool), bed.copy()
    covered = np.isfinite(level)  # the pile covers at least half of the cell
    if mode == "no_flow":
        return covered, bed.copy()
    emergent = covered & (level >= np.asarray(water_surface, float))
    return emergent, bed + np.asarray(lift, float)


@numba.njit(cache=True)
def pile_columns(x, y, bed, pos, radius, use, sub, top, solid, dsum):
    """Per cell (sub × sub sub-points): highest sphere top ``top`` (−inf: none), mean solid chord length
    ``solid`` (m) and chord-weighted diameter sum ``dsum`` (m²) of the spheres *use*."""
    ny, nx = bed.shape
    dx = x[1] - x[0] if nx > 1 else 1.0
    dy = y[1] - y[0] if ny > 1 else 1.0
    w = 1.0 / (sub * sub)
    for p in range(pos.shape[0]):
        if not use[p]:
            continue
        r = radius[p]
        i0 = max(int(np.floor((pos[p, 0] - r - x[0]) / dx + 0.5)), 0)
        i1 = min(int(np.floor((pos[p, 0] + r - x[0]) / dx + 0.5)), nx - 1)
        j0 = max(int(np.floor((pos[p, 1] - r - y[0]) / dy + 0.5)), 0)
        j1 = min(int(np.floor((pos[p, 1] + r - y[0]) / dy + 0.5)), ny - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                for a in range(sub):
                    px = _sub_point(x[i], a, sub, dx)
                    for b in range(sub):
                        py = _sub_point(y[j], b, sub, dy)
                        d2 = (px - pos[p, 0]) ** 2 + (py - pos[p, 1]) ** 2
                        if d2 < r * r:
                            half = np.sqrt(r * r - d2)
                            zt = pos[p, 2] + half
                            if zt > top[j, i]:
                                top[j, i] = zt
                            # chord below the top, above the bed
                            lo = max(pos[p, 2] - half, bed[j, i])
                            c = max(zt - lo, 0.0)
                            solid[j, i] += w * c
                            dsum[j, i] += w * c * 2.0 * r


@numba.njit(cache=True)
def pile_layer_solids(x, y, bed, pos, radius, use, sub, height, solid):
    """Per cell, the mean solid chord length (m) of the spheres *use* inside each of the ``K =
    solid.shape[2]`` equal layers between the bed and the pile height *height* (bottom first), over
    ``sub × sub`` sub-points: ``solid[j, i, k] / (height / K)`` is the layer's solid fraction."""
    ny, nx = bed.shape
    K = solid.shape[2]
    dx = x[1] - x[0] if nx > 1 else 1.0
    dy = y[1] - y[0] if ny > 1 else 1.0
    w = 1.0 / (sub * sub)
    for p in range(pos.shape[0]):
        if not use[p]:
            continue
        r = radius[p]
        i0 = max(int(np.floor((pos[p, 0] - r - x[0]) / dx + 0.5)), 0)
        i1 = min(int(np.floor((pos[p, 0] + r - x[0]) / dx + 0.5)), nx - 1)
        j0 = max(int(np.floor((pos[p, 1] - r - y[0]) / dy + 0.5)), 0)
        j1 = min(int(np.floor((pos[p, 1] + r - y[0]) / dy + 0.5)), ny - 1)
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                H = height[j, i]
                if H <= 0.0:
                    continue
                t = H / K
                b = bed[j, i]
                for a in range(sub):
                    px = _sub_point(x[i], a, sub, dx)
                    for c in range(sub):
                        py = _sub_point(y[j], c, sub, dy)
                        d2 = (px - pos[p, 0]) ** 2 + (py - pos[p, 1]) ** 2
                        if d2 < r * r:
                            half = np.sqrt(r * r - d2)
                            hi = pos[p, 2] + half - b
                            lo = max(pos[p, 2] - half - b, 0.0)
                            for k in range(K):
                                ov = min(hi, (k + 1) * t) - max(lo, k * t)
                                if ov > 0.0:
                                    solid[j, i, k] += w * ov


def _rev_average(a, sy, sx):
    """Gaussian-weighted sum of *a* around each cell (standard deviations *sy*, *sx* in cells, truncated at
    3 sigma, nothing outside the grid); *a* unchanged for sigmas below a tenth of a cell."""
    if max(sy, sx) < 0.1:
        return a.copy()
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(a, sigma=(sy, sx), mode="constant", cval=0.0, truncate=3.0)


def porous_pile(x, y, bed, pos, radius, resting, law: str | None = None, sub: int = 8, min_porosity: float = 0.2,
                rev: float | None = None, layers: int = PILE_LAYERS):
    """The :class:`~breachflow.swe.porous.PorousPile` of the resting spheres (see the module docstring).

    Porosity and stone size are volume averages over a representative elementary volume (Bear 1972,
    *Dynamics of fluids in porous media*, §1.3): ``n = 1 - sum w V_solid / sum w V_pile`` and
    ``d = sum w chord d / sum w chord`` over the pile cells, with Gaussian weights ``w`` of standard
    deviation ``rev / 2`` (``rev`` in m, default the volume-weighted mean stone diameter ``D``; a packing
    repeating every ``D`` keeps 0.7 % of its cell-to-cell variation). A single cell smaller than a
    stone is not such a volume: it holds the middle of one sphere (``n`` -> 0) or the void between two
    (``n`` -> 1), and Forchheimer's ``(1 - n) / n^3`` turns that into impervious cells beside nearly
    frictionless lanes (a pile of 2 m spheres on 1 m cells then passed 5.6-22 % less than the
    Dupuit-Forchheimer discharge of its packing, ``tests/swe/test_porous.py``). The porosity is taken so
    for each of the column's *layers* equal layers between the bed and the pile height
    (:mod:`breachflow.swe.porous`; ``V_pile`` the layer's volume, ``V_solid`` the spheres' inside it) and
    clipped to ``[min_porosity, 0.95]``. The pile height stays per cell (the crest the water flows over).
    """
    from ..swe.porous import PorousPile

    x, y, bed, pos, radius, resting = _contiguous(x, y, bed, pos, radius, resting)
    top = np.full(bed.shape, -np.inf)
    solid = np.zeros(bed.shape)
    dsum = np.zeros(bed.shape)
    pile_columns(x, y, bed, pos, radius, resting, int(sub), top, solid, dsum)
    height = np.where(np.isfinite(top), np.maximum(top - bed, 0.0), 0.0)
    has = (height > 0) & (solid > 0)
    height = np.where(has, height, 0.0)
    layer_solid = np.zeros(bed.shape + (int(layers),))
    pile_layer_solids(x, y, bed, pos, radius, resting, int(sub), height, layer_solid)
    if rev is None:
        r = radius[resting[:radius.size]] if radius.size else radius
        rev = float(np.sum(2 * r * r ** 3) / np.sum(r ** 3)) if r.size else 0.0
    dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
    dy = abs(y[1] - y[0]) if y.size > 1 else 1.0

    def rev_average(a):
        return _rev_average(np.where(has, a, 0.0), 0.5 * rev / dy, 0.5 * rev / dx)

    vol = rev_average(height / layers)  # every layer's volume per unit area
    porosity = np.stack([np.where(has, 1.0 - rev_average(layer_solid[..., k]) / np.where(has, vol, 1.0), 1.0)
                         for k in range(int(layers))], axis=-1)
    sol, dsm = rev_average(solid), rev_average(dsum)
    diameter = np.where(has, dsm / np.where(has & (sol > 0), sol, 1.0), 1.0)
    return PorousPile.build(height, porosity.mean(axis=-1), diameter, law=law, min_porosity=min_porosity,
                            layer_porosity=porosity)
