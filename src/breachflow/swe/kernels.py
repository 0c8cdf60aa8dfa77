"""Numba kernels of the finite-volume shallow-water solver (docs/theory.md, *Shallow-water equations*): the time loop :func:`advance`.

Conserved variables ``h, hu, hv`` on a structured grid padded with ``G = 2`` ghost layers
(arrays ``(ny + 4, nx + 4)``, index ``[j, i]``, x along axis 1; :mod:`.layout`). Per stage:

1. ghost cells from the boundary conditions (:func:`.ghosts.fill_ghosts`);
2. primitive variables ``u, v, eta = h + z`` and the CFL rate (:func:`.step.primitives`), the column
   range of each row whose update is not negligible (:func:`.step.activity`; water at rest and dry land
   cost no flux work);
3. MUSCL reconstruction, hydrostatic reconstruction and HLL(C) fluxes (:mod:`.fluxes`), flux divergence
   with the well-balanced bed-slope source and a forward-Euler update with implicit Manning friction,
   fused by rows (:func:`.step.stage`); two stages combined as SSP-RK2 (Heun) give second order in time.
4. in a porous pile (:mod:`.porous`), the implicit Forchheimer resistance after each step (Lie
   splitting), inside the same loop so the quiet-cell ranges carry over from step to step.
"""
from __future__ import annotations

import math

import numpy as np

from .ghosts import fill_ghosts, ghost_bed_slopes, relax_outer_velocity  # noqa: F401  (re-exported)
from .porous import porous_resistance_box
from .layout import (BC_DISCHARGE, BC_LEVEL, BC_OUTFLOW, BC_WALL, EAST, LIMITERS, NORTH,  # noqa: F401
                     RIEMANN, SOUTH, WEST, G, _jit)
from .step import activity, copy_interior, primitives, stage


@_jit
def _range_cells(lo, hi):
    n = 0
    for j in range(lo.shape[0]):
        if hi[j] >= lo[j]:
            n += hi[j] - lo[j] + 1
    return n


@_jit
def advance(h, hu, hv, z, obst, manning, bed_dz, kinds, times, levels, discharges, outer_un, relaxation,
            dx, dy, g, second_order, limiter, riemann, courant, h_dry,
            t, t_stop, max_steps, dt_min, skip_quiet, quiet_tol, blocks,
            h1, hu1, hv1, u, v, eta, stats, pile_h, pile_A, pile_B, pile_n, pile_box):
    """March from *t* to *t_stop* (or *max_steps*) with adaptive CFL steps.

    *skip_quiet*: quiet cells (:func:`.step.activity`, relative tolerance *quiet_tol*; 0: only cells
    whose update is exactly zero, same results) skip the flux work; *blocks*: blocks of rows run in
    parallel (the numba thread count). With a non-empty *pile_box* ``(j0, j1, i0, i1)`` (padded indices)
    the porous pile's resistance (:func:`.porous.porous_resistance_box` with the pile height *pile_h*, its
    layers' *pile_A*, *pile_B* ``(ny, nx, K)`` and the free-surface Manning *pile_n*) is applied after every
    step (Lie splitting).
    Returns ``(t, steps, status)``; status 0 = reached t_stop,
    1 = step limit, 2 = non-finite state or a time step below *dt_min* (runaway).
    ``stats[0] += clipped depth``, ``stats[1] = min dt``, ``stats[2] = max dt``, ``stats[3] +=``
    cell-stages that did the flux work (the others were quiet).
    """
    nyp, nxp = h.shape
    rows = np.zeros(nyp)
    # column ranges per row (ghost rows: empty) of the first and second stage and their hull
    lo1 = np.full(nyp, nxp, np.int64)
    hi1 = np.full(nyp, -1, np.int64)
    lo2 = lo1.copy()
    hi2 = hi1.copy()
    clo = lo1.copy()
    chi = hi1.copy()
    full = True  # the first check of a call examines every cell (the state may have been edited)
    steps = 0
    while t < t_stop and steps < max_steps:
        fill_ghosts(h, hu, hv, z, bed_dz, kinds, times, levels, discharges, outer_un, t, h_dry, g)
        primitives(h, hu, hv, z, obst, u, v, eta, h_dry, dx, dy, g, True, rows)
        rate = rows.max()
        if not (rate == rate) or rate == math.inf:
            return t, steps, 2
        if rate > 0.0:
            dt = courant / rate
        else:
            dt = t_stop - t
        if t + dt > t_stop:
            dt = t_stop - t
        elif t + 1.5 * dt > t_stop:  # avoid a tiny last step
            dt = 0.5 * (t_stop - t)
        if dt < dt_min and t + dt < t_stop:
            return t, steps, 2
        for j in range(nyp):  # cells that changed since the last check: those of either stage
            clo[j] = min(lo1[j], lo2[j])
            chi[j] = max(hi1[j], hi2[j])
        activity(h, hu, hv, eta, obst, lo1, hi1, clo, chi, full, skip_quiet, quiet_tol, g)
        full = False
        stats[3] += _range_cells(lo1, hi1)
        stats[0] += stage(h, hu, hv, u, v, eta, obst, lo1, hi1, h, hu, hv, manning, dx, dy, g, second_order, limiter,
                          riemann, dt, h_dry, 0.0, h1, hu1, hv1, blocks)
        if second_order:
            fill_ghosts(h1, hu1, hv1, z, bed_dz, kinds, times, levels, discharges, outer_un, t + dt, h_dry, g)
            primitives(h1, hu1, hv1, z, obst, u, v, eta, h_dry, dx, dy, g, False, rows)
            activity(h1, hu1, hv1, eta, obst, lo2, hi2, lo1, hi1, False, skip_quiet, quiet_tol, g)
            stats[3] += _range_cells(lo2, hi2)
            stats[0] += stage(h1, hu1, hv1, u, v, eta, obst, lo2, hi2, h, hu, hv, manning, dx, dy, g, second_order,
                              limiter, riemann, dt, h_dry, 0.5, h, hu, hv, blocks)
        else:
            copy_interior(h1, h)
            copy_interior(hu1, hu)
            copy_interior(hv1, hv)
        relax_outer_velocity(h, hu, hv, outer_un, relaxation, dt, h_dry)
        if pile_box[1] > pile_box[0]:
            porous_resistance_box(h, hu, hv, pile_h, pile_A, pile_B, pile_n, dt, g, h_dry, pile_box[0], pile_box[1],
                                  pile_box[2], pile_box[3])
        t += dt
        steps += 1
        if dt < stats[1]:
            stats[1] = dt
        if dt > stats[2]:
            stats[2] = dt
        # cheap finiteness probe on a few cells each step; the full check is done by the caller
        if not (h[G, G] == h[G, G]):
            return t, steps, 2
    return t, steps, 0 if t >= t_stop else 1
