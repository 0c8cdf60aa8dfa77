"""Coarse-to-fine start of a cold steady solve (grid sequencing).

A cold start fills the flood side, breaks through the breach and spreads the jet over the polder before
the flow settles: about a minute of simulated time for the typical breach, every one of them at the fine grid's cost per
cell and step. The same transient on cells ``factor`` times larger costs about ``factor³`` less (fewer
cells, longer steps), and its steady state, laid on the fine grid
(the warm start from another grid of
:class:`~breachflow.swe.solver.SWESimulation`: the wet-weighted water surface on the fine bed, the
velocities interpolated), leaves the fine solve only the local correction: the grid sequencing of steady CFD solvers.

The fine solve's steady-state test is the same as from the cold start (tolerance, monitored region and
breach section), so the answer is the fine grid's steady state within that tolerance; the coarse level
only shortens the way there. ``[hydro] cold_start = "coarse"`` selects it for a closure run's first
solve (default ``"cold"``: the fine grid from the initial state).
"""
from __future__ import annotations

import time as _time

import numpy as np

#: the first solve's start: from the initial state on the run's grid, or from the steady state of a
#: coarser grid
COLD_STARTS = ("cold", "coarse")


def coarse_region(region, index, shape) -> np.ndarray | None:
    """The coarse cells holding a cell of the fine *region* (boolean mask); None stays None."""
    if region is None:
        return None
    jy, ix = index
    out = np.zeros(shape, bool)
    J, I = np.nonzero(np.asarray(region, bool))
    out[jy[J], ix[I]] = True
    return out


def coarse_surface(dom, index, cdom) -> np.ndarray | None:
    """The initial water surface of *dom* on the coarse grid: the mean over the block's wet fine cells (NaN
    where the whole block is dry), so that a filled basin stays filled and dry land stays dry."""
    if dom.initial_surface is None:
        return None
    jy, ix = index
    J, I = np.meshgrid(jy, ix, indexing="ij")
    flat = (J * cdom.shape[1] + I).ravel()
    n = cdom.shape[0] * cdom.shape[1]
    eta = np.asarray(dom.initial_surface, float)
    wet = np.isfinite(eta) & (eta > dom.bed) & ~dom.obstacle
    total = np.bincount(flat, weights=np.where(wet, eta, 0.0).ravel(), minlength=n)
    count = np.bincount(flat, weights=wet.ravel().astype(float), minlength=n)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan).reshape(cdom.shape)


class CoarseStartSWE:
    """A cold :class:`~breachflow.swe.solver.SWESolver` *solver* started from its own steady state
    on a grid *factor* times coarser (module docstring). Warm starts (an *initial* state) go to *solver*
    unchanged. ``last_info`` holds the CPU time (s) and simulated time (s) of both levels."""

    def __init__(self, solver, factor: int = 2):
        if int(factor) < 2:
            from ..errors import InputError

            raise InputError(f"coarse start: factor must be at least 2, got {factor!r}")
        self.solver, self.factor = solver, int(factor)
        self.last = None
        self.last_info: dict = {}

    def __getattr__(self, name):  # options, tolerance, region, section... of the wrapped solver
        return getattr(self.__dict__["solver"], name)

    def solve(self, domain, obstacles=None, initial=None):
        from ..swe.solver import SWESimulation, _mask
        from .far_field import coarse_domain

        s = self.solver
        if initial is not None:
            out = s.solve(domain, obstacles=obstacles, initial=initial)
            self.last = s.last
            return out
        dom = domain if obstacles is None else domain.with_obstacles(_mask(obstacles, domain))
        c0 = _time.process_time()
        cdom, index = coarse_domain(dom, self.factor)
        cdom.initial_surface = coarse_surface(dom, index, cdom)
        csim = SWESimulation(cdom, s.options)
        region = None if s.region is None else coarse_region(_mask(s.region, dom), index, cdom.shape)
        csim.run_to_steady(s.tolerance, s.t_max, s.check_interval, region=region, section=s.section,
                           average=s.average)
        coarse = csim.snapshot(derived=False)
        c1 = _time.process_time()
        out = s.solve(dom, initial=coarse)
        self.last = s.last
        self.last_info = {"coarse_cpu": c1 - c0, "coarse_time": csim.t, "coarse_cells": int(np.prod(cdom.shape)),
                          "fine_cpu": _time.process_time() - c1, "fine_time": s.last.t,
                          "coarse_converged": bool(csim.history.converged)}
        out.attrs["hydro_cold_start"] = (f"coarse x{self.factor}: {csim.t:.0f} s on {cdom.shape[1]} x {cdom.shape[0]} "
                                         f"cells, then {s.last.t:.0f} s on the run's grid")
        return out
