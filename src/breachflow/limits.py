"""Sizes a run may not exceed: checked before anything of that size is allocated (docs/run-safety.md).

One definition for the scenario's plausibility checks (:mod:`breachflow.scenario.plausibility`) and the
grid builder of the shallow-water solver (:func:`breachflow.swe.domain.uniform_grid`).
"""
from __future__ import annotations

from .errors import InputError

#: the most particles a run may hold (``batch × max_cycles``): every cycle file stores all of them
MAX_PARTICLES = 1_000_000

#: the most cells of a hydrodynamic grid: each is about 20 float64 state arrays (about 0.2 kB a cell);
#: 2e7 cells is about 4 GB
MAX_CELLS = 20_000_000


def check_grid_size(nx: int, ny: int, dx: float, dy: float, extent) -> None:
    """Refuse a grid of more than :data:`MAX_CELLS` cells before it is allocated, naming its size."""
    cells = float(nx) * float(ny)
    if not cells <= MAX_CELLS:
        x0, x1, y0, y1 = extent
        raise InputError(f"the hydrodynamic grid would have {nx:,} × {ny:,} = {cells:.3g} cells of {dx:.4g} × {dy:.4g} m "
                         f"over x {x0:.6g}…{x1:.6g} m, y {y0:.6g}…{y1:.6g} m; at most {MAX_CELLS:.3g} fit in memory. "
                         f"Use a coarser [hydro] resolution or a smaller extent (check the units of the lengths)")

