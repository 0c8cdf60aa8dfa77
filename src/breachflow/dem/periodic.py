"""Periodic axes of the DEM domain (docs/theory.md, *DEM contact*): minimum-image differences, wrapping into the period, and the
test for leaving the domain on the non-periodic axes. Shared by the neighbour search (:mod:`.neighbours`,
:mod:`.bins`) and the compiled step loop (:mod:`.steploop`)."""
from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always", error_model="numpy")
def min_image(dx, L, periodic):
    """Minimum-image difference ``dx - L round(dx / L)`` for a periodic axis of length *L*. Wrapped
    coordinates differ by less than L/2 for most pairs: those skip the division (same result)."""
    if periodic and (dx >= 0.5 * L or dx < -0.5 * L):
        dx -= L * math.floor(dx / L + 0.5)
    return dx


@numba.njit(cache=True, inline="always", error_model="numpy")
def wrapped(x, lo, L):
    """*x* wrapped into the periodic range ``[lo, lo + L)``: ``x - L floor((x - lo) / L)``. Inside the range the
    floor is 0 (``0 < x - lo < L`` gives a quotient below 1 after rounding) and the division is skipped: the
    same result, bit for bit."""
    u = x - lo
    if u > 0.0 and u < L:
        return x - 0.0
    return x - L * math.floor(u / L)


@numba.njit(cache=True, inline="always", error_model="numpy")
def outside(x, y, z, box, px, py):
    """Whether ``(x, y, z)`` lies outside *box* (xmin, xmax, ymin, ymax, zmin, zmax) on its non-periodic axes."""
    return ((not px and (x < box[0] or x > box[1])) or (not py and (y < box[2] or y > box[3]))
            or z < box[4] or z > box[5])
