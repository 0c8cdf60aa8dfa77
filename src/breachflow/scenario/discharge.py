"""Breach discharge estimates (docs/theory.md, *Breach discharge*; report §2.4 Table 2.6, §2.7 weir representation).

* :func:`breach_discharge` — area × mean velocity, ``Q_D = h_W B v`` (Table 2.6 uses v = 3 m/s).
* :func:`weir_discharge` — broad-crested weir over a trapezoidal breach (Fread's BREACH / DAMBRK form)::

      Q = k_s C (b H^1.5 + (c_2/c_1) m_W H^2.5),   c_2/c_1 = 2.45/3.1

  with ``b`` the breach bottom width, ``H`` the head of the flood-side water above the breach bottom,
  ``m_W`` the wall slope (1V:m_W H) and ``C`` the weir coefficient. The report quotes C = 3.0–3.2 in
  US customary units (ft^0.5/s; Fread 1996), i.e. 1.66–1.77 m^0.5/s. The submergence factor
  ``k_s = 1 - 27.8 (h_t/H - 0.67)^3`` for a tailwater head ``h_t`` above the breach bottom with
  ``h_t/H > 0.67`` (Fread 1988) is applied when a tailwater is given.
"""
from __future__ import annotations

import warnings

import numpy as np
import xarray as xr

from ..errors import BreachflowWarning, InputError
from .geometry import DEFAULT_WALL_SLOPE, BreachGeometry
from .quantities import ATTRS, as_dataarray, si_input

#: Report's broad-crested weir coefficient range (Fread 1996), ft^0.5/s.
WEIR_COEFFICIENT_RANGE_US = (3.0, 3.2)
_FT_SQRT = 0.3048 ** 0.5
#: The same range in SI, m^0.5/s.
WEIR_COEFFICIENT_RANGE = (WEIR_COEFFICIENT_RANGE_US[0] * _FT_SQRT, WEIR_COEFFICIENT_RANGE_US[1] * _FT_SQRT)
#: Fread's side-slope (triangular) coefficient relative to the rectangular one: 2.45 / 3.1.
SIDE_TO_BOTTOM_COEFFICIENT = 2.45 / 3.1


def breach_discharge(surge_height, breach_length, mean_velocity="3 m/s"):
    """Area × mean velocity: ``Q_D = h_W B v`` (report Table 2.6, v = 3 m/s). Returns float or DataArray (m^3/s)."""
    h = si_input(surge_height, name="surge_height", kind="length", positive=True)
    b = si_input(breach_length, name="breach_length", kind="length", positive=True)
    v = si_input(mean_velocity, name="mean_velocity", kind="speed", positive=True)
    q = h * b * v
    if isinstance(q, xr.DataArray):
        return as_dataarray(q, "breach_discharge", {**ATTRS["breach_discharge"], "method": "area x mean velocity"})
    return float(q)


def weir_discharge(head, *, bottom_width=None, wall_slope=DEFAULT_WALL_SLOPE, breach: BreachGeometry | None = None,
                   coefficient="3.1 ft**0.5/s", tailwater=None):
    """Broad-crested weir discharge through a trapezoidal breach (m^3/s); see the module docstring.

    Give the breach as ``breach=BreachGeometry`` or as ``bottom_width`` and ``wall_slope`` (H per V, default
    :data:`~breachflow.scenario.geometry.DEFAULT_WALL_SLOPE`; 0 for vertical walls). ``head`` is
    the flood-side water height above the breach bottom; ``tailwater`` the protected-side water height
    above the breach bottom (optional). A coefficient outside the report's 3.0–3.2 ft^0.5/s warns.
    """
    if breach is not None:
        if bottom_width is not None:
            raise InputError("weir_discharge: give either breach= or bottom_width=, not both")
        b, m = breach.bottom_width, breach.wall_slope
    else:
        if bottom_width is None:
            raise InputError("weir_discharge: bottom_width (or breach=) is required")
        b = si_input(bottom_width, name="bottom_width", kind="length", nonnegative=True)
        m = si_input(wall_slope, name="wall_slope", kind="dimensionless", nonnegative=True)
    h = si_input(head, name="head", kind="length", nonnegative=True)
    c = si_input(coefficient, name="coefficient", kind="m**0.5/s", positive=True)
    lo, hi = WEIR_COEFFICIENT_RANGE
    if np.any(np.asarray(c) < lo * (1 - 1e-9)) or np.any(np.asarray(c) > hi * (1 + 1e-9)):
        warnings.warn(f"weir coefficient {np.asarray(c) / _FT_SQRT} ft^0.5/s is outside the report's range "
                      f"{WEIR_COEFFICIENT_RANGE_US} (Fread 1996)", BreachflowWarning, stacklevel=2)
    q = c * (b * h ** 1.5 + SIDE_TO_BOTTOM_COEFFICIENT * m * h ** 2.5)
    if tailwater is not None:
        ht = si_input(tailwater, name="tailwater", kind="length", nonnegative=True)
        q = q * submergence_factor(h, ht)
    if isinstance(q, xr.DataArray):
        return as_dataarray(q, "breach_discharge", {**ATTRS["breach_discharge"], "method": "broad-crested weir"})
    return float(q)


def submergence_factor(head, tailwater):
    """Fread's submergence correction ``1 - 27.8 (h_t/H - 0.67)^3`` for ``h_t/H > 0.67``, floored at 0."""
    ratio = xr.where(head > 0, tailwater / xr.where(head > 0, head, 1.0), 1.0) if isinstance(
        head, xr.DataArray) or isinstance(tailwater, xr.DataArray) else (tailwater / head if head > 0 else 1.0)
    k = 1.0 - 27.8 * (np.maximum(ratio, 0.67) - 0.67) ** 3
    return np.clip(k, 0.0, 1.0)
