"""Warm re-solve of the closure cycle in a local region (issue 16; docs/theory.md, *The closure cycle* cycle <g>, step re-solve).

A cycle's remap changes a few cells at the breach; the flow far from them hardly moves. ``resolve =
"region"`` re-solves only a region around the changed cells and keeps the rest of the domain frozen at
the previous steady state:

* region: the bounding box of the changed cells and of the breach section, plus ``margin`` (m) on each
  side, on the same grid (a sub-array of the domain, nothing is interpolated);
* edge conditions of the region from the previous steady state, the machinery of the nested local model
  (:func:`breachflow.hydro.nested.edge_conditions`): where water enters, the previous water level
  (absorbing; supercritical inflow: level and unit discharge), where it leaves free outflow, obstacle
  cells walls; region sides on the domain's own edge keep the domain's boundary conditions;
* steady state judged on the breach discharge and on depth and discharge of the monitoring region
  (the breach vicinity) inside the region, as the full re-solve;
* growth: after the solve the water level in the outer ``band`` cells of every interior region side is
  compared with the previous state; where it moved by more than ``edge_level`` (m) the change reached
  the edge, the region's margin is doubled and the solve re-run (warm, from the merged state);
* fall back to the full domain when the region would hold more than ``max_fraction`` of its cells: the
  full re-solve from the previous steady state, as ``resolve = "full"`` (from the region's merged state
  instead it stopped 4.0–5.7 % below it on the typical breach, ``bench region_wp``: the far field's slow rise
  passed the rate test after one check);
* the far field (``far``, :mod:`breachflow.hydro.far_field`): ``frozen`` keeps the previous state
  outside the region; ``coarse`` adds the level change of a coarse full-domain solve to the previous
  state — the region's edge levels, its warm start and the merged state outside it — so that the rise
  of the whole flood-side pool when the pile cuts the flow reaches the region's edges.

The returned snapshot is the full domain: the region's state merged into the frozen previous one, with
``hydro_region`` (the region and its growth) in its attributes.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from .nested import GRAVITY, edge_conditions
from ..swe.domain import BoundaryCondition, Domain
from ..swe.solver import WINDOW_CHANGE

#: margin (m) around the changed cells, in breach lengths when the section is known
DEFAULT_MARGIN_B = 2.0


def _clip_side(bcs, s_full: np.ndarray, i0: int, i1: int) -> list:
    """The boundary conditions *bcs* of a side whose cells have along-side coordinates *s_full*, restricted
    to cells ``i0:i1`` (per-cell arrays of values are sliced to the stretch)."""
    out = []
    for bc in bcs:
        sel = np.ones(s_full.size, bool)
        if bc.start is not None:
            sel &= s_full >= bc.start
        if bc.stop is not None:
            sel &= s_full <= bc.stop
        idx = np.flatnonzero(sel)
        keep = idx[(idx >= i0) & (idx < i1)]
        if keep.size == 0:
            continue
        kw = {}
        for which in ("level", "discharge"):
            val = getattr(bc, which)
            if val is None or callable(val) or np.ndim(val) == 0 or (bc.times is not None and np.ndim(val) == 1):
                kw[which] = val
            else:  # one value per cell of the stretch (last axis)
                kw[which] = np.asarray(val)[..., keep - idx[0]]
        out.append(BoundaryCondition(bc.kind, level=kw["level"], discharge=kw["discharge"], times=bc.times,
                                     start=float(s_full[keep[0]]), stop=float(s_full[keep[-1]]),
                                     absorbing=bc.absorbing))
    return out


def region_domain(domain: Domain, previous: xr.Dataset, box, *, name: str = "region"):
    """The sub-domain of *domain* on cells ``box = (j0, j1, i0, i1)`` (end exclusive), its edge conditions
    from the previous steady state *previous* (a grid snapshot of *domain*'s grid) on interior sides and
    from *domain* on sides that lie on the domain's edge."""
    j0, j1, i0, i1 = box
    ny, nx = domain.shape
    sl = (slice(j0, j1), slice(i0, i1))
    sub = Domain(x=domain.x[i0:i1], y=domain.y[j0:j1], bed=domain.bed[sl], manning=domain.manning[sl],
                 obstacle=domain.obstacle[sl], name=f"{domain.name} {name}", crs_wkt=domain.crs_wkt)
    for a in ("x", "y"):
        sub.__dict__["_spacing_" + a] = domain.dx if a == "x" else domain.dy
    pile = getattr(domain, "porous", None)
    if pile is not None:
        from ..swe.porous import PorousPile

        sub.porous = PorousPile(**{k: getattr(pile, k)[sl] for k in ("height", "porosity", "diameter", "A", "B",
                                                                     "layer_porosity", "layer_A", "layer_B")},
                                law=pile.law)
    bed0 = np.asarray(previous["bed_elevation"].values, float)[sl]
    h = np.asarray(previous["depth"].values, float)[sl]
    wet = h > 1e-3
    u = np.where(wet, np.asarray(previous["u"].values, float)[sl], 0.0)
    v = np.where(wet, np.asarray(previous["v"].values, float)[sl], 0.0)
    inside = ~sub.obstacle
    hmax = float(np.max(h)) if h.size else 1.0
    L = max(sub.x[-1] - sub.x[0], sub.y[-1] - sub.y[0]) + domain.dx
    relaxation = 4.0 * L / np.sqrt(GRAVITY * max(hmax, 1e-3))
    # the previous level on the edge cells (the bed may have been raised under the pile: level, not depth)
    edges = edge_conditions(bed0, h, u, v, inside, sub, relaxation)
    # edge cells whose condition holds the previous state (water entering: level, or level and discharge);
    # where it leaves, free outflow lets the level follow the new flow
    un_in = {"west": u[:, 0], "east": -u[:, -1], "south": v[0, :], "north": -v[-1, :]}
    wet_in = {"west": (wet & inside)[:, 0], "east": (wet & inside)[:, -1], "south": (wet & inside)[0, :],
              "north": (wet & inside)[-1, :]}
    sub.held_edges = {side: wet_in[side] & (un_in[side] >= 0.0) for side in un_in}
    on_edge = {"west": i0 == 0, "east": i1 == nx, "south": j0 == 0, "north": j1 == ny}
    along = {"west": (domain.y, j0, j1), "east": (domain.y, j0, j1), "south": (domain.x, i0, i1),
             "north": (domain.x, i0, i1)}
    bounds = {}
    for side in ("west", "east", "south", "north"):
        if on_edge[side]:
            s_full, a, b = along[side]
            # sides not given are walls; keep that explicitly on the sub-domain
            bounds[side] = [BoundaryCondition.wall()] + _clip_side(domain.boundaries.get(side, []), s_full, a, b)
        else:
            bounds[side] = edges[side]
    sub.boundaries = bounds
    return sub


def changed_cells(domain: Domain, previous: xr.Dataset, previous_pile=None) -> np.ndarray:
    """Cells whose bed, no-flow mask or porous pile differ between *domain* and the previous state."""
    ch = np.abs(domain.bed - np.asarray(previous["bed_elevation"].values, float)) > 1e-9
    if "obstacle" in previous:
        ch |= domain.obstacle != np.asarray(previous["obstacle"].values).astype(bool)
    pile = getattr(domain, "porous", None)
    h_new = pile.height if pile is not None else 0.0
    h_old = previous_pile.height if previous_pile is not None else 0.0
    ch |= np.abs(np.broadcast_to(h_new, domain.shape) - np.broadcast_to(h_old, domain.shape)) > 1e-9
    return ch


def _shifted(previous: xr.Dataset, d_eta: np.ndarray) -> xr.Dataset:
    """*previous* with its water level raised by *d_eta* (m) on its wet cells (velocities kept)."""
    h = np.asarray(previous["depth"].values, float)
    out = previous.copy()
    out["depth"] = previous["depth"].copy(data=np.where(h > 1e-3, np.maximum(h + d_eta, 0.0), h))
    return out


def _section_discharge(ds: xr.Dataset, section) -> float:
    """Discharge (m³/s) of the snapshot *ds* across *section* ``(x0, x1, y)``: the breach discharge the
    closure reports and the solver's monitor judges (:func:`~breachflow.swe.section.snapshot_discharge`)."""
    from ..swe.section import snapshot_discharge

    x0, x1, y = (float(v) for v in section)
    return snapshot_discharge(ds, (x0, x1), y)


class RegionResolver:
    """Re-solve a warm start in a local region (module docstring); a drop-in for the warm
    :class:`~breachflow.swe.solver.SWESolver` *full* (its options, tolerance, t_max, region and
    section are used).

    *margin* (m) around the changed cells (default ``2 B``, B the breach section's length, else 20 cells);
    *edge_level* (m) the level change in the outer *band* cells of an interior side that grows the region;
    *max_fraction* of the domain's cells above which the full domain is solved instead; *max_grow* the
    number of growths before falling back to the full domain; *far* the far-field model (a name in
    :data:`~breachflow.hydro.far_field.far_fields`), *far_factor* the coarsening of ``coarse``.
    ``last_info`` describes the last solve (region, cells, growths)."""

    def __init__(self, full, margin: float | None = None, edge_level: float = 0.03, band: int = 2,
                  max_fraction: float = 0.5, max_grow: int = 3, far: str = "frozen", far_factor: int | None = None,
                 far_passes: int = 3, far_level: float = 0.002):
        from .far_field import far_fields

        if margin is not None and not margin > 0:
            raise InputError(f"region re-solve: margin must be > 0 m, got {margin!r}")
        if not edge_level > 0:
            raise InputError(f"region re-solve: edge_level must be > 0 m, got {edge_level!r}")
        if not 0 < max_fraction <= 1:
            raise InputError(f"region re-solve: max_fraction must be in (0, 1], got {max_fraction!r}")
        self.full, self.margin, self.edge_level, self.band = full, margin, edge_level, int(band)
        self.max_fraction, self.max_grow = max_fraction, int(max_grow)
        self.far = far_fields.get(far)(full, **({} if far_factor is None else {"factor": far_factor}))
        self.far_name = far
        self.far_passes, self.far_level = int(far_passes), float(far_level)
        self.last = None
        self.last_info: dict = {}
        self._pile = None

    def _box(self, domain: Domain, changed: np.ndarray, margin: float):
        ny, nx = domain.shape
        jj, ii = np.nonzero(changed)
        xs = [domain.x[ii.min()], domain.x[ii.max()]]
        ys = [domain.y[jj.min()], domain.y[jj.max()]]
        sec = self.full.section
        if sec is not None:
            xs += [float(sec[0]), float(sec[1])]
            ys += [float(sec[2])]
        x0, x1, y0, y1 = min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin
        i0 = int(np.clip(np.searchsorted(domain.x, x0), 0, nx))
        i1 = int(np.clip(np.searchsorted(domain.x, x1, side="right"), 0, nx))
        j0 = int(np.clip(np.searchsorted(domain.y, y0), 0, ny))
        j1 = int(np.clip(np.searchsorted(domain.y, y1, side="right"), 0, ny))
        return j0, j1, i0, i1

    def _full(self, domain, obstacles, initial, why, edge_change=None, grown=0):
        out = self.full.solve(domain, obstacles=obstacles, initial=initial)
        self.last = self.full.last
        self.last_info = {"mode": "full", "why": why, "cells": int(np.prod(domain.shape)), "grown": grown}
        if edge_change is not None:  # the level changes at the region's edges that made it grow (m)
            self.last_info["edge_change"] = dict(edge_change)
        edge = f"; edge level change {max(edge_change.values()):.3f} m" if edge_change else ""
        out.attrs["hydro_region"] = f"full domain ({why}{edge})"
        return out

    def solve(self, domain: Domain, obstacles=None, initial=None) -> xr.Dataset:
        from ..swe.solver import SWESimulation, _mask, _same_grid

        pile = getattr(domain, "porous", None)
        try:
            if initial is None or not isinstance(initial, xr.Dataset) or not _same_grid(initial, domain):
                return self._full(domain, obstacles, initial, "cold start")
            dom = domain if obstacles is None else domain.with_obstacles(_mask(obstacles, domain))
            changed = changed_cells(dom, initial, self._pile)
            if not changed.any():
                return self._full(dom, None, initial, "no cell changed")
            sec = self.full.section
            margin = self.margin if self.margin is not None else (
                DEFAULT_MARGIN_B * abs(float(sec[1]) - float(sec[0])) if sec is not None else 20.0 * domain.dx)
            ncell = dom.shape[0] * dom.shape[1]
            region = None if self.full.region is None else _mask(self.full.region, dom)
            box = self._box(dom, changed, margin)
            fits = (box[1] - box[0]) * (box[3] - box[2]) <= self.max_fraction * ncell
            d_eta = self.far.level_change(dom, initial, self._pile, box) if fits else None  # else: full at once
            q_prev = _section_discharge(initial, sec) if sec is not None else None
            scale, passes, grown, state = 1.0, 0, 0, initial
            far_info = {}
            while True:  # passes: the far field's level change rescaled to the region's breach discharge
                base = initial if d_eta is None else _shifted(initial, scale * d_eta)
                h0 = np.asarray(base["depth"].values, float)
                eta0 = np.asarray(base["bed_elevation"].values, float) + h0
                if state is initial:
                    state = base
                while True:  # growth of the region while the change reaches its edge
                    box = self._box(dom, changed, margin)
                    j0, j1, i0, i1 = box
                    if (j1 - j0) * (i1 - i0) > self.max_fraction * ncell or grown > self.max_grow:
                        why = (f"region {i1 - i0} x {j1 - j0} cells > {self.max_fraction:g} of the domain"
                               if grown <= self.max_grow else f"change still at the region edge after {self.max_grow} growths")
                        # from the previous steady state, not from the region's merged state: the full
                        # re-solve from the latter stops with the far field still at its old level (the
                        # pool's slow rise passes the rate test), docs/performance.md, *Studies behind the defaults*
                        out = self._full(dom, None, initial, why, getattr(self, "_edge_change", None) if grown else None,
                                         grown)
                        self.last_info.update(far_info)
                        self.far.accept(out)
                        return out
                    sub = region_domain(dom, base, box)
                    sl = (slice(j0, j1), slice(i0, i1))
                    reg = None
                    if region is not None and region[sl].any():
                        reg = region[sl]
                    sim = SWESimulation(sub, self.full.options, initial=state.isel(y=sl[0], x=sl[1]))
                    sim.run_to_steady(self.full.tolerance, self.full.t_max, self.full.check_interval, region=reg,
                                      section=sec, average=getattr(self.full, "average", False) and sec is not None,
                                      window=getattr(self.full, "window", None) if sec is not None else None,
                                      window_change=getattr(self.full, "window_change", WINDOW_CHANGE))
                    # outside the region the (shifted) previous state; every earlier region lies inside this one
                    h_new = h0.copy()
                    hu_new = h0 * np.asarray(base["u"].values, float)
                    hv_new = h0 * np.asarray(base["v"].values, float)
                    h_new[sl], (hu_new[sl], hv_new[sl]) = sim.depth, sim.discharge
                    merged = self._snapshot(dom, sim, (h_new, hu_new, hv_new))
                    state = merged
                    if not self._edge_moved(dom, box, sim, eta0[sl], h0[sl]):
                        break
                    grown += 1
                    margin *= 2.0
                if d_eta is None:
                    break
                passes += 1
                far_info = {"far": self.far_name, "far_cpu": self.far.last_cpu, "far_scale": scale, "far_passes": passes,
                            "far_max_level_change": float(np.max(np.abs(scale * d_eta)))}
                new_scale = self.far.scale(q_prev, sim.section_discharge(sec)) if sec is not None else None
                if new_scale is None or passes >= self.far_passes:
                    break
                step = abs(new_scale - scale) * float(np.max(np.abs(d_eta[sl])))
                scale = new_scale
                if step < self.far_level:
                    break
            self.last = sim
            self.last_info = {"mode": "region", "box": box, "edge_change": dict(self._edge_change), "cells": (j1 - j0) * (i1 - i0), "grown": grown,
                              "fraction": (j1 - j0) * (i1 - i0) / ncell, **far_info}
            merged.attrs["hydro_region"] = (
                f"x {dom.x[i0] - 0.5 * dom.dx:g}..{dom.x[i1 - 1] + 0.5 * dom.dx:g}, y {dom.y[j0] - 0.5 * dom.dy:g}.."
                f"{dom.y[j1 - 1] + 0.5 * dom.dy:g} m ({i1 - i0} x {j1 - j0} cells, "
                f"{100 * (j1 - j0) * (i1 - i0) / ncell:.1f} % of the domain; grown {grown} times; edge level "
                f"change {max(self._edge_change.values(), default=0.0):.3f} m"
                + (f"; far field {self.far_name}, level change up to {far_info['far_max_level_change']:.3f} m"
                   if far_info else "") + ")")
            self.far.accept(merged)
            return merged
        finally:
            self._pile = pile

    def _edge_moved(self, dom, box, sim, eta_old, h_old) -> bool:
        """Did the water level move by more than ``edge_level`` in the outer band of an interior side, next
        to its edge cells that hold the previous state (water entering the region)?"""
        j0, j1, i0, i1 = box
        ny, nx = dom.shape
        b = self.band
        held = sim.domain.held_edges
        eta = sim.domain.bed + sim.depth
        wet = (sim.depth > 1e-3) | (h_old > 1e-3)
        d = np.where(wet & ~sim.domain.obstacle, np.abs(eta - np.where(h_old > 1e-3, eta_old, sim.domain.bed)), 0.0)
        bands = {}
        if i0 > 0:
            bands["west"] = d[:, :b][held["west"]]
        if i1 < nx:
            bands["east"] = d[:, -b:][held["east"]]
        if j0 > 0:
            bands["south"] = d[:b, :].T[held["south"]]
        if j1 < ny:
            bands["north"] = d[-b:, :].T[held["north"]]
        moved = {k: float(a.max()) for k, a in bands.items() if a.size}
        self._edge_change = moved
        return any(v > self.edge_level for v in moved.values())

    def _snapshot(self, dom, sim, state) -> xr.Dataset:
        """The full-domain snapshot of *state* with *sim*'s convergence history and counters."""
        from ..swe.solver import SWESimulation

        full = SWESimulation(dom, self.full.options, initial=state)
        full.history, full.t, full.steps = sim.history, sim.t, sim.steps
        return full.snapshot(**self.full.derived_kwargs)
