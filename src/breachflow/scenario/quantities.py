"""Boundary conversion of scenario inputs to SI scalars or DataArrays, and result attributes (docs/theory.md, *Units and notation*).

Scalars stay Python floats. A list, array or array-valued Quantity becomes a DataArray whose dimension is
named after the parameter, so ``fall_rate=["0.3 m/h", "0.02 m/h"]`` sweeps along a ``fall_rate``
dimension. A DataArray keeps its own dimensions (its ``units`` attribute names the unit).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pint
import xarray as xr

from ..errors import InputError
from ..units import to_si, ureg

HOUR = 3600.0

#: Units and long names of every scenario variable; one place, used by every result.
ATTRS: dict[str, dict] = {
    "surge_height": {"units": "m", "long_name": "flood-side water height above ground at the breach at the crest (h_W)"},
    "rise_rate": {"units": "m/s", "long_name": "flood-side stage rise rate before the crest", "display_units": "cm/h"},
    "fall_rate": {"units": "m/s", "long_name": "flood-side stage fall rate after the crest", "display_units": "cm/h"},
    "polder_area": {"units": "m^2", "long_name": "polder area (A_P)", "display_units": "ha"},
    "inundation_depth": {"units": "m", "long_name": "permissible average polder inundation depth (d_I)"},
    "breach_discharge": {"units": "m^3/s", "long_name": "breach discharge into the polder (Q_D)"},
    "pump_capacity": {"units": "m^3/s", "long_name": "polder pumping capacity (Q_P)"},
    "breach_length": {"units": "m", "long_name": "breach length along the levee centreline (B)"},
    "mean_velocity": {"units": "m/s", "long_name": "mean velocity through the breach"},
    "breach_time": {"units": "s", "long_name": "time of breaching relative to the flood crest (negative: before)", "display_units": "h"},
    "flood_end_time": {"units": "s", "long_name": "end of the flood relative to the crest", "display_units": "h"},
    "polder_rise_rate": {"units": "m/s", "long_name": "polder stage rise rate (Q_D - Q_P) / A_P (r_P)", "display_units": "cm/h"},
    "balance_time": {"units": "s", "long_name": "breach balance time t_Q, elapsed from the breach", "display_units": "h"},
    "inundation_time": {"units": "s", "long_name": "polder inundation time t_I, elapsed from the breach", "display_units": "h"},
    "closure_window": {"units": "s", "long_name": "breach closure window t_B = min(t_Q, t_I), elapsed from the breach", "display_units": "h"},
    "depth_at_window_end": {"units": "m", "long_name": "average polder water depth at the end of the closure window", "display_units": "cm"},
    "balance_reached": {"units": "1", "long_name": "breach balance is reached within the flood"},
    "inundation_reached": {"units": "1", "long_name": "permissible inundation depth is reached before the balance and within the flood"},
    "governing": {
        "units": "1", "long_name": "constraint governing the closure window",
        "flag_values": np.array([0, 1, 2], dtype="i1"),
        "flag_meanings": "breach_balance polder_inundation no_limit_within_flood",
    },
    "wind_limit": {"units": "m/s", "long_name": "crane operating wind-speed limit"},
    "work_start_delay": {"units": "s", "long_name": "delay from the breach until the wind allows crane work", "display_units": "h"},
    "working_time": {"units": "s", "long_name": "time for closure work inside the window after the wind delay", "display_units": "h"},
    "wind_calm_reached": {"units": "1", "long_name": "the wind drops below the crane limit within the wind record"},
}

GOVERNING_NAMES = ("breach balance", "polder inundation", "no balance within the flood")


def si_input(value: Any, *, name: str, kind: str, default_unit: str | None = None,
             positive: bool = False, nonnegative: bool = False):
    """Convert one user input to SI: float for a scalar, DataArray (dim *name* unless it has its own)."""
    if value is None:
        raise InputError(f"{name}: a value is required")
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim > 0):
        items = [to_si(v, name=f"{name}[{i}]", kind=kind, default_unit=default_unit, positive=positive,
                       nonnegative=nonnegative) for i, v in enumerate(value)]
        return _tag(xr.DataArray(np.asarray(items, dtype=float), dims=name, name=name), name, kind)
    if isinstance(value, pint.Quantity) and np.ndim(value.magnitude) > 0:
        mags = to_si(value, name=name, kind=kind, positive=positive, nonnegative=nonnegative)
        return _tag(xr.DataArray(np.asarray(mags, dtype=float).ravel(), dims=name, name=name), name, kind)
    out = to_si(value, name=name, kind=kind, default_unit=default_unit, positive=positive, nonnegative=nonnegative)
    if isinstance(out, xr.DataArray):
        # a dimension coordinate that carries the values themselves (polder_area along polder_area) is
        # converted with them, so that results line up with other SI inputs along the same dimension
        for cname in list(out.coords):
            coord = value.coords[cname]
            if (coord.dims == value.dims and coord.ndim == 1 and np.issubdtype(coord.dtype, np.number)
                    and np.array_equal(np.asarray(coord.values, float), np.asarray(value.values, float))):
                out = out.assign_coords({cname: (coord.dims, np.asarray(out.values, float))})
        out = out.rename(name)
        return _tag(out, name, kind)
    if isinstance(out, np.ndarray):
        return _tag(xr.DataArray(out.ravel(), dims=name, name=name), name, kind)
    return float(out)


def _tag(da: xr.DataArray, name: str, kind: str) -> xr.DataArray:
    attrs = dict(da.attrs)
    attrs.update(ATTRS.get(name, {}))
    if name not in ATTRS:
        from ..units import SI_UNITS

        attrs["units"] = SI_UNITS.get(kind, kind) or "1"
    da.attrs = attrs
    if name in da.dims and name not in da.coords:
        da = da.assign_coords({name: da.values})
        da[name].attrs = {k: v for k, v in attrs.items() if k in ("units", "long_name")}
    return da


def as_dataarray(value, name: str, attrs: dict | None = None) -> xr.DataArray:
    """Wrap a float or DataArray as a named DataArray with the package attributes of *name*."""
    da = value if isinstance(value, xr.DataArray) else xr.DataArray(np.asarray(value))
    da = da.rename(name)
    da.attrs = dict(attrs if attrs is not None else ATTRS.get(name, {}))
    return da


def display(value_si: float, si_unit: str, display_unit: str, digits: int = 3) -> str:
    """Text of an SI magnitude in *display_unit*, e.g. ``display(20520, 's', 'h') -> '5.7 h'``."""
    if value_si is None or not np.isfinite(value_si):
        return "—"
    q = ureg.Quantity(float(value_si), si_unit).to(display_unit)
    return f"{q.magnitude:.{digits}g} {display_unit}"


def check_finite(name: str, value) -> None:
    """Raise InputError naming *name* if any element is NaN or infinite."""
    arr = value.values if isinstance(value, xr.DataArray) else np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: value is not finite")
