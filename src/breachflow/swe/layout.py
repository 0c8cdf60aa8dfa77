"""Padded-grid layout, boundary-kind codes and the numba decorators shared by the SWE kernels.

Conserved variables ``h, hu, hv`` live on a structured grid padded with ``G = 2`` ghost layers
(arrays ``(ny + 4, nx + 4)``, index ``[j, i]``, x along axis 1).
"""
from __future__ import annotations

import numba

G = 2  # ghost layers

# boundary kinds (per boundary cell)
BC_OUTFLOW = 0
BC_WALL = 1
BC_LEVEL = 2
BC_DISCHARGE = 3

# sides
WEST, EAST, SOUTH, NORTH = 0, 1, 2, 3

LIMITERS = {"minmod": 0, "mc": 1, "vanleer": 2}
RIEMANN = {"hll": 0, "hllc": 1}

_jit = numba.njit(cache=True, fastmath=False, nogil=True)
_pjit = numba.njit(cache=True, fastmath=False, nogil=True, parallel=True)
