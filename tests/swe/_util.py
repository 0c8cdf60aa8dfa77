"""Small domain builders shared by the shallow-water tests."""
from __future__ import annotations

import numpy as np

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid


def channel(n, length, surface, bed=0.0, width=1.0, west=None, east=None, **kwargs):
    """A one-cell-wide channel of *n* cells along x (walls on the long sides)."""
    bounds = {"west": [west or BC.outflow()], "east": [east or BC.outflow()]}
    return uniform_grid(0.0, length, 0.0, width, length / n, dy=width, bed=bed, initial_surface=surface,
                        boundaries=bounds, **kwargs)


def cell_average(func, x, dx, samples=16):
    """Cell averages of func(x) by midpoint quadrature with *samples* points per cell."""
    offs = (np.arange(samples) + 0.5) / samples - 0.5
    xs = np.asarray(x)[:, None] + offs[None, :] * dx
    return func(xs.ravel()).reshape(xs.shape).mean(axis=1)


def run(domain, t_end, **options):
    sim = SWESimulation(domain, SWEOptions(**options))
    return sim.advance_to(t_end)


def observed_orders(errors):
    e = np.asarray(errors, float)
    return np.log2(e[:-1] / e[1:])
