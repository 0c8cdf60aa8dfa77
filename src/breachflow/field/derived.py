"""Fields derived from a depth-averaged flow (docs/theory.md, *Incipient motion and stone stability*, report §3.2.1, Fig 3.3).

All functions take SI arrays (depth h, velocity u, v, bed z, Manning n) and return zeros on dry
cells (``h <= DRY_DEPTH``).

- speed ``|u| = sqrt(u² + v²)``; Froude number ``Fr = |u| / sqrt(g h)``;
- unit discharge ``q = h |u|`` (m²/s); total head ``H = z + h + |u|²/(2g)`` (m; NaN where dry);
- bed shear stress (Manning) ``tau = rho_F g n² |u|² / h^(1/3)`` (Pa);
- Shields incipient grain size ``D = tau / ((G_S - 1) rho_F g tau*_c)`` (m), report eq. 3.8.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from .snapshot import DRY_DEPTH

RHO_WATER = 1000.0
SPECIFIC_GRAVITY_SOIL = 2.65
CRITICAL_SHIELDS = 0.047


def _wet(h):
    return np.asarray(h, float) > DRY_DEPTH


def speed(u, v):
    return np.hypot(np.asarray(u, float), np.asarray(v, float))


def froude(h, u, v, g=9.81):
    h = np.asarray(h, float)
    wet = _wet(h)
    return np.where(wet, speed(u, v) / np.sqrt(g * np.where(wet, h, 1.0)), 0.0)


def unit_discharge(h, u, v):
    return np.where(_wet(h), np.asarray(h, float) * speed(u, v), 0.0)


def total_head(z, h, u, v, g=9.81):
    h = np.asarray(h, float)
    return np.where(_wet(h), np.asarray(z, float) + h + speed(u, v) ** 2 / (2 * g), np.nan)


#: Manning's n is s m^(-1/3); UDUNITS (hence CF) has no fractional powers and reads "s m-1/3" as
#: (1/3) s m-1, so the file stores the number in the SI convention (units "1") and says so.
MANNING_ATTRS = {"long_name": "Manning roughness coefficient", "units": "1",
                 "comment": "Manning's n in the SI convention V = R^(2/3) S^(1/2) / n (V in m s-1, R in m), "
                            "i.e. in s m^(-1/3); stored as a number because UDUNITS cannot express a 1/3 power"}


def bed_shear_stress(h, u, v, manning_n, g=9.81, rho=RHO_WATER):
    """``tau = rho g n² |u|² / h^(1/3)`` (Pa), docs/theory.md, *Incipient motion and stone stability*."""
    h = np.asarray(h, float)
    wet = _wet(h)
    n = np.asarray(manning_n, float)
    return np.where(wet, rho * g * n**2 * speed(u, v) ** 2 / np.cbrt(np.where(wet, h, 1.0)), 0.0)


def incipient_grain_size(tau, specific_gravity=SPECIFIC_GRAVITY_SOIL, critical_shields=CRITICAL_SHIELDS,
                         g=9.81, rho=RHO_WATER):
    """``D = tau / ((G_S - 1) rho g tau*_c)`` (m): the grain diameter at incipient motion (report eq. 3.8)."""
    if not (specific_gravity > 1 and critical_shields > 0):
        raise InputError(f"incipient grain size needs G_S > 1 and tau*_c > 0 (got {specific_gravity}, {critical_shields})")
    return np.asarray(tau, float) / ((specific_gravity - 1.0) * rho * g * critical_shields)


def derived_fields(z, h, u, v, manning_n, *, g=9.81, rho=RHO_WATER, specific_gravity=SPECIFIC_GRAVITY_SOIL,
                   critical_shields=CRITICAL_SHIELDS) -> dict:
    """All derived fields as ``name: (array, attrs)`` ready for ``grid_snapshot(extra=...)``."""
    tau = bed_shear_stress(h, u, v, manning_n, g, rho)
    return {
        "speed": (speed(u, v), {"long_name": "depth-averaged flow speed", "units": "m s-1"}),
        "froude_number": (froude(h, u, v, g), {"long_name": "Froude number |u|/sqrt(g h)", "units": "1"}),
        "unit_discharge": (unit_discharge(h, u, v), {"long_name": "unit discharge h |u|", "units": "m2 s-1"}),
        "total_head": (total_head(z, h, u, v, g), {"long_name": "total head z + h + |u|^2/(2 g)", "units": "m"}),
        "bed_shear_stress": (tau, {"long_name": "bed shear stress (Manning)", "units": "Pa"}),
        "manning_n": (np.broadcast_to(np.asarray(manning_n, float), np.shape(h)).copy(),
                      dict(MANNING_ATTRS)),
        "incipient_grain_size": (incipient_grain_size(tau, specific_gravity, critical_shields, g, rho),
                                 {"long_name": "grain diameter at incipient motion (Shields)", "units": "m",
                                  "specific_gravity": specific_gravity, "critical_shields": critical_shields}),
    }


def add_derived(ds: xr.Dataset, manning_n, **kwargs) -> xr.Dataset:
    """Add the derived fields to a grid snapshot (2-D or with a time dim); returns a new Dataset."""
    out = ds.copy()
    dims = ds.depth.dims
    n = manning_n.values if isinstance(manning_n, xr.DataArray) else manning_n
    fields = derived_fields(ds.bed_elevation.values, ds.depth.values, ds.u.values, ds.v.values,
                            np.broadcast_to(np.asarray(n, float), ds.bed_elevation.shape), **kwargs)
    for name, (a, attrs) in fields.items():
        out[name] = (dims if np.ndim(a) == len(dims) else ("y", "x"), a, attrs)
    return out


def peak_speed(ds: xr.Dataset, *, x_range=None, y_range=None) -> dict:
    """Largest depth-averaged speed of a grid snapshot (optionally inside x/y ranges, m) and where it is."""
    s = speed(ds.u.values, ds.v.values)
    if s.ndim == 3:
        s = s[-1]
    X, Y = np.meshgrid(ds.x.values, ds.y.values)
    sel = np.ones(s.shape, bool)
    if x_range is not None:
        sel &= (X >= x_range[0]) & (X <= x_range[1])
    if y_range is not None:
        sel &= (Y >= y_range[0]) & (Y <= y_range[1])
    if not sel.any():
        raise InputError(f"peak_speed: no cells in x {x_range}, y {y_range}")
    masked = np.where(sel, s, -1.0)
    j, i = np.unravel_index(int(np.argmax(masked)), s.shape)
    depth = ds.depth.values if ds.depth.ndim == 2 else ds.depth.values[-1]
    return {"speed": float(s[j, i]), "x": float(X[j, i]), "y": float(Y[j, i]), "depth": float(depth[j, i])}
