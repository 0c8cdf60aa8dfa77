"""The pocket of a rough bed in the terrain contact: ``tan(phi0)`` of a grain in a pocket of bed grains
(Wiberg & Smith 1987; the physics and its sources: :mod:`breachflow.fluid.bed`, ``docs/bed-and-forces.md``).

A height field whose contact properties carry two more columns ``(d_bed, z_star)`` after the eight of
``boundaries._wall_props`` is a rough bed: the contact's friction and rolling
resistance are at least :func:`pocket_tangent` of the particle's diameter (``walls._wall_loop``). With the
eight columns (a smooth bed) the contact is computed as before, bit for bit.
"""
from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def pocket_tangent(diameter, d_bed, z_star):
    """``tan(phi0)``, ``cos(phi0) = (D/d + z*) / (D/d + 1)``, of a grain of *diameter* ``D`` in a pocket of a bed
    of grains *d_bed* ``d`` (Wiberg & Smith 1987); 0 for ``d_bed <= 0`` (smooth bed)."""
    if d_bed <= 0.0:
        return 0.0
    r = diameter / d_bed
    c = (r + z_star) / (r + 1.0)
    if c >= 1.0:
        return 0.0
    if c <= 0.0:
        return math.inf
    return math.sqrt(1.0 - c * c) / c
