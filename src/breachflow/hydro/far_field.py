"""The far field of the region re-solve (issue 16; :mod:`breachflow.hydro.resolve_region`).

A region re-solve keeps the domain outside the region at the previous steady state and takes its edge
levels from there. When the pile cuts the breach flow, the whole flood-side pool rises (the drawdown
towards the breach shrinks; a weir estimate gives ΔQ/Q ≈ 1.5 Δη/H at the breach), so the true edge
levels move and no region smaller than the pool holds the change. A far-field model gives the region
the level change Δη of the far field; the region's edges and warm start are the previous state plus
Δη, and the merged snapshot outside the region is the previous state plus Δη (velocities kept).

Far-field models (registry :data:`far_fields`, ``[hydro] resolve_far``), one method
``level_change(dom, previous, previous_pile, box) -> Δη (ny, nx)`` (or None: no change), *dom* the
domain with the pile, *previous* the previous steady state (its bed and no-flow mask, *previous_pile*
its porous pile), *box* the region ``(j0, j1, i0, i1)``:

* ``frozen``: no change, the previous state as it was (the plain region re-solve);
* ``coarse``: the same domain on cells ``factor`` times larger (bed averaged over the open fine cells,
  no-flow where at least half the fine cells are, porous pile averaged: :func:`coarse_domain`), solved to steady state with the
  pile and without it; Δη is the difference of the two coarse levels, interpolated bilinearly to the fine
  cells (the coarse model's own bias, e.g. a breach width off by part of a coarse cell, cancels to first
  order: only its response to the pile is used — as the nested model takes its edges from a regional
  one). Its steady state before the pile is kept for the next re-solve when that starts from the state
  this one returned, so a closure cycle pays for one coarse solve per re-solve (two for the first).
  A coarse solve costs about ``factor^-3`` of a fine one (``factor^2`` fewer cells, ``factor`` times
  longer time steps).

Measured (issue 16; ``python3 tasks.py bench region_far``), ``coarse`` does not
beat the full re-solve: the steady states of the pool judged near the breach still drift by centimetres
far from it, in the fine and in the coarse model alike, so the coarse level change outside the region is
not the fine one (on the scene of ``tests/cycle/test_region_resolve.py``, 1.5–1.7 m cells, 6 m margin:
mean rise outside the region 9–13 mm against 1.2–1.4 mm of the full re-solve, breach discharge
+1.2…+1.8 % off it against +0.2…+0.4 % frozen); the default stays ``frozen`` and ``[hydro] resolve =
"full"``.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from ..registry import Registry
from ..swe.domain import BoundaryCondition, Domain

#: far-field models of the region re-solve, by name (``[hydro] resolve_far``)
far_fields: Registry = Registry("region far-field model", "breachflow.region_far_fields")


@far_fields.register("frozen")
class FrozenFarField:
    """The far field stays at the previous steady state (Δη = 0)."""

    def __init__(self, full=None):
        self.full = full
        self.last_cpu = 0.0

    def level_change(self, dom: Domain, previous: xr.Dataset, previous_pile, box):
        return None

    def scale(self, q_previous: float, q_region: float):
        """The factor on the level change once the region's breach discharge is known (None: keep it)."""
        return None

    def accept(self, returned: xr.Dataset) -> None:
        """The re-solve returned *returned* (the next re-solve's warm start, usually)."""


def _block_index(fine: np.ndarray, coarse: np.ndarray, spacing: float) -> np.ndarray:
    """Index of the coarse cell holding each fine cell centre."""
    lo = coarse[0] - 0.5 * spacing
    return np.clip(((fine - lo) / spacing).astype(int), 0, coarse.size - 1)


def coarse_domain(dom: Domain, factor: int) -> tuple[Domain, tuple[np.ndarray, np.ndarray]]:
    """*dom* on cells about *factor* times larger covering the same extent, and the coarse cell index
    ``(jy, ix)`` of every fine row / column. Bed: mean over the block's open fine cells; no-flow where at
    least half the block is (a wall one fine cell thick stays watertight at *factor* 2, not beyond); Manning n: block mean; the same boundary conditions (per-cell values
    interpolated along the side); a porous pile: height averaged over the block, porosity (each layer's) and
    stone size averaged over its pile cells."""
    from ..swe.domain import uniform_grid

    ny, nx = dom.shape
    dx, dy = dom.dx, dom.dy
    x0, x1 = dom.x[0] - 0.5 * dx, dom.x[-1] + 0.5 * dx
    y0, y1 = dom.y[0] - 0.5 * dy, dom.y[-1] + 0.5 * dy
    ncx, ncy = max(4, int(round(nx / factor))), max(4, int(round(ny / factor)))
    c = uniform_grid(x0, x1, y0, y1, (x1 - x0) / ncx, (y1 - y0) / ncy)
    ix = _block_index(dom.x, c.x, c.dx)
    jy = _block_index(dom.y, c.y, c.dy)
    J, I = np.meshgrid(jy, ix, indexing="ij")
    flat = (J * c.x.size + I).ravel()
    n = c.x.size * c.y.size

    def block_sum(a):
        return np.bincount(flat, weights=np.asarray(a, float).ravel(), minlength=n).reshape(c.shape)

    count = block_sum(np.ones(dom.shape))
    open_ = ~dom.obstacle
    n_open = block_sum(open_)
    c.obstacle = n_open <= 0.5 * count
    bed_open = block_sum(np.where(open_, dom.bed, 0.0))
    c.bed = np.where(n_open > 0, bed_open / np.maximum(n_open, 1), block_sum(dom.bed) / count)
    c.manning = block_sum(dom.manning) / count
    c.name = f"{dom.name} coarse x{factor}"
    c.crs_wkt = dom.crs_wkt
    c.boundaries = {side: [_coarse_bc(bc, dom, c, side) for bc in bcs] for side, bcs in dom.boundaries.items()}
    pile = getattr(dom, "porous", None)
    if pile is not None and pile.any:
        from ..swe.porous import PorousPile

        where = pile.height > 0
        n_pile = block_sum(where)
        mean_on_pile = lambda a: block_sum(np.where(where, a, 0.0)) / np.maximum(n_pile, 1)
        layers = np.stack([mean_on_pile(pile.layer_porosity[..., k]) for k in range(pile.layer_porosity.shape[-1])],
                          axis=-1)
        c.porous = PorousPile.build(block_sum(pile.height) / count, mean_on_pile(pile.porosity),
                                    mean_on_pile(pile.diameter), law=pile.law, layer_porosity=layers)
    return c, (jy, ix)


def _coarse_bc(bc: BoundaryCondition, fine: Domain, coarse: Domain, side: str) -> BoundaryCondition:
    """*bc* of *fine*'s side on the coarse grid: per-cell values interpolated along the side."""
    s_f = fine.y if side in ("west", "east") else fine.x
    s_c = coarse.y if side in ("west", "east") else coarse.x
    sel_f = np.ones(s_f.size, bool)
    sel_c = np.ones(s_c.size, bool)
    if bc.start is not None:
        sel_f &= s_f >= bc.start
        sel_c &= s_c >= bc.start
    if bc.stop is not None:
        sel_f &= s_f <= bc.stop
        sel_c &= s_c <= bc.stop
    kw = {}
    for which in ("level", "discharge"):
        val = getattr(bc, which)
        if val is None or callable(val) or np.ndim(val) == 0 or (bc.times is not None and np.ndim(val) == 1):
            kw[which] = val
        else:  # one value per fine cell of the stretch (last axis): interpolate to the coarse cells
            arr = np.asarray(val, float)
            sf, sc = s_f[sel_f], s_c[sel_c]
            kw[which] = np.stack([np.interp(sc, sf, row) for row in arr.reshape(-1, arr.shape[-1])]).reshape(
                arr.shape[:-1] + (sc.size,))
    start, stop = bc.start, bc.stop
    if np.ndim(kw["level"]) > 0 and not callable(kw["level"]) or np.ndim(kw["discharge"]) > 0 and not callable(kw["discharge"]):
        if not sel_c.any():  # the stretch holds no coarse cell centre: nearest coarse cell
            k = int(np.argmin(np.abs(s_c - s_f[sel_f].mean())))
            start = stop = float(s_c[k])
    return BoundaryCondition(bc.kind, level=kw["level"], discharge=kw["discharge"], times=bc.times, start=start,
                             stop=stop, absorbing=bc.absorbing)


def _previous_domain(dom: Domain, previous: xr.Dataset, previous_pile) -> Domain:
    """*dom* as it was in the state *previous*: its bed, no-flow mask and pile."""
    from dataclasses import replace

    old = replace(dom, bed=np.asarray(previous["bed_elevation"].values, float),
                  obstacle=np.asarray(previous["obstacle"].values).astype(bool) if "obstacle" in previous
                  else dom.obstacle.copy())
    for a in ("x", "y"):
        if hasattr(dom, "_spacing_" + a):
            old.__dict__["_spacing_" + a] = getattr(dom, "_spacing_" + a)
    old.porous = previous_pile
    return old


@far_fields.register("coarse")
class CoarseFarField:
    """The far field's response from a coarse full-domain solve (module docstring). *full* the warm
    :class:`~breachflow.swe.solver.SWESolver` (options, tolerance, t_max, section); *factor* the
    coarsening (cells ``factor`` times larger, ≥ 2)."""

    def __init__(self, full, factor: int = 4):
        if int(factor) != factor or factor < 2:
            raise InputError(f"region re-solve: the coarse far field needs an integer factor >= 2, got {factor!r}")
        self.full, self.factor = full, int(factor)
        self._kept = None  # (snapshot returned by the re-solve, coarse steady state of it)
        self.last_cpu = 0.0
        self._pending = None

    def _solve(self, cdom: Domain, initial, region, tolerance):
        from ..swe.solver import SWESimulation

        sim = SWESimulation(cdom, self.full.options, initial=initial)
        sim.run_to_steady(tolerance, self.full.t_max, None, region=region, section=self.full.section)
        return sim

    def level_change(self, dom: Domain, previous: xr.Dataset, previous_pile, box):
        import time

        c0 = time.process_time()
        tol = self.full.tolerance
        cdom, (jy, ix) = coarse_domain(dom, self.factor)
        j0, j1, i0, i1 = box
        region = np.zeros(cdom.shape, bool)  # the coarse cells over the region: its edges must have settled
        region[jy[j0]:jy[j1 - 1] + 1, ix[i0]:ix[i1 - 1] + 1] = True
        region &= ~cdom.obstacle
        if self._kept is not None and self._kept[0] is previous:
            old = self._kept[1]
        else:  # the coarse steady state of the previous domain, warm from the previous fine state
            cold_dom, _ = coarse_domain(_previous_domain(dom, previous, previous_pile), self.factor)
            sim = self._solve(cold_dom, previous, region, tol)
            old = (sim.domain.bed + sim.depth, sim.depth.copy(), sim.discharge, self._q(sim))
        h = np.where(old[1] > 0, np.maximum(old[0] - cdom.bed, 0.0), 0.0)  # the old surface on the new bed
        sim = self._solve(cdom, (h, *old[2]), region, tol)
        new = (sim.domain.bed + sim.depth, sim.depth.copy(), sim.discharge, self._q(sim))
        self._q_coarse = (old[3], new[3])
        self._pending = new
        wet = (old[1] > 1e-3) & (new[1] > 1e-3) & ~cdom.obstacle
        d = np.where(wet, new[0] - old[0], np.nan)
        self.last_cpu = time.process_time() - c0
        self.last_coarse = {"shape": cdom.shape, "time": sim.t, "converged": sim.history.converged,
                            "q_before": old[3], "q": new[3]}
        return _to_fine(d, cdom, dom)

    def _q(self, sim):
        return sim.section_discharge(self.full.section) if self.full.section is not None else float("nan")

    def scale(self, q_previous: float, q_region: float):
        """``(Q_prev |Q_prev| - Q_w |Q_w|) / (Q_c,prev |Q_c,prev| - Q_c |Q_c|)``: the drawdown of the pool
        towards the breach (velocity head and friction) goes with Q²; the coarse model gives its shape,
        the region's breach discharge Q_w its size (the coarse pile, averaged over larger cells, cuts the
        flow less than the fine one). Clipped to [0, 4]; None when the coarse discharge hardly changed."""
        qc0, qc1 = self._q_coarse
        den = qc0 * abs(qc0) - qc1 * abs(qc1)
        if not np.isfinite(den) or abs(den) <= 1e-3 * qc0 * qc0:
            return None
        return float(np.clip((q_previous * abs(q_previous) - q_region * abs(q_region)) / den, 0.0, 4.0))

    def accept(self, returned: xr.Dataset) -> None:
        if self._pending is not None:
            self._kept = (returned, self._pending)
            self._pending = None


def _to_fine(d: np.ndarray, cdom: Domain, dom: Domain) -> np.ndarray:
    """Bilinear interpolation of the coarse field *d* (NaN where undefined) to *dom*'s cells, undefined
    values not counted (normalised convolution); 0 where no defined coarse value is near."""
    from scipy.interpolate import RegularGridInterpolator

    ok = np.isfinite(d)
    Y, X = np.meshgrid(dom.y, dom.x, indexing="ij")

    def on_fine(a):
        return RegularGridInterpolator((cdom.y, cdom.x), a, bounds_error=False, fill_value=None)((Y, X))

    w = on_fine(ok.astype(float))
    v = on_fine(np.where(ok, d, 0.0))
    return np.where(w > 1e-9, v / np.where(w > 1e-9, w, 1.0), 0.0)
