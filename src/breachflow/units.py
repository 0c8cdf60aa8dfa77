"""The package's single pint unit registry and the boundary conversion to SI (docs/theory.md, *Units and notation*).

Every user-facing quantity goes through :func:`to_si` exactly once, at the boundary (CLI, TOML, API
arguments). Inside the package all numbers are SI magnitudes (m, s, kg, Pa) without units attached.

Accepted inputs: a string with units (``"2.8 m"``, ``"9.2 ft"``, ``"40 cm/hr"``, ``"800 ha"``,
``"7060 cfs"``), a :class:`pint.Quantity`, an :class:`xarray.DataArray` whose ``attrs["units"]`` names
its unit, or a bare number / array where a documented default unit exists.

``ureg`` is also pint's application registry, set up as pint-xarray needs it (``force_ndarray_like``; it
reads UDUNITS exponents such as ``m s-1``), so ``ds.pint.quantify()`` works on every file breachflow
writes whichever of breachflow and pint_xarray is imported first. Magnitudes are numpy scalars/arrays.
"""
from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pint

from .errors import UnitError, InputError

#: UDUNITS/CF exponents (``m s-1``, ``m2 s-1``, ``kg m-3``) become pint powers; the pattern is
#: cf_xarray's (from MetPy): a letter followed by a signed integer, not inside a number like ``1e-3``.
_UDUNITS_EXPONENT = re.compile(r"(?<=[A-Za-z])(?![A-Za-z])(?<![0-9\-][eE])(?<![0-9\-])(?=[0-9\-])")


def _udunits_powers(text: str) -> str:
    return _UDUNITS_EXPONENT.sub("**", text)


# force_ndarray_like: what pint-xarray requires of a registry (``pint_xarray.setup_registry``), set at
# creation so that ``ds.pint.quantify()`` works whichever of breachflow and pint_xarray is imported first
# (pint-xarray keeps ``pint.get_application_registry()``, a proxy that follows ``set_application_registry``).
ureg = pint.UnitRegistry(autoconvert_offset_to_baseunit=True, force_ndarray_like=True,
                         preprocessors=[str, _udunits_powers])
ureg.define("cfs = foot ** 3 / second")
ureg.define("cms = meter ** 3 / second")
Q_ = ureg.Quantity
pint.set_application_registry(ureg)

#: Canonical SI unit of each physical kind used in the package.
SI_UNITS = {
    "length": "m",
    "area": "m**2",
    "volume": "m**3",
    "time": "s",
    "speed": "m/s",
    "rate": "m/s",  # rise / fall rate of a stage
    "discharge": "m**3/s",
    "unit_discharge": "m**2/s",
    "density": "kg/m**3",
    "mass": "kg",
    "force": "N",
    "stiffness": "N/m",
    "damping": "N*s/m",
    "rot_damping": "N*m*s",
    "pressure": "Pa",
    "kinematic_viscosity": "m**2/s",
    "acceleration": "m/s**2",
    "dimensionless": "",
    "manning": "s/m**(1/3)",
}


_NUMBER = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")
_UDUNITS_POWER = re.compile(r"(?<=[A-Za-z])(-?\d+)")


def normalise_unit_text(unit: str) -> str:
    """Accept UDUNITS/CF exponent style: ``m3/s`` → ``m**3/s``, ``m s-1`` → ``m s**-1``."""
    return _UDUNITS_POWER.sub(r"**\1", unit)


def _parse_text(text: str):
    m = _NUMBER.match(text)
    if m:
        number, unit = text[: m.end()], text[m.end():]
        return ureg.Quantity(float(number), normalise_unit_text(unit.strip()) or "")
    return ureg.Quantity(normalise_unit_text(text))


def _dimensionality(kind: str):
    try:
        unit = SI_UNITS[kind]
    except KeyError:  # an explicit unit expression
        unit = kind
    return ureg.Quantity(1.0, normalise_unit_text(unit)).dimensionality, unit


def parse_quantity(value: Any, *, name: str, kind: str, default_unit: str | None = None) -> pint.Quantity:
    """Turn *value* into a pint Quantity of the dimension *kind*, or raise :class:`~breachflow.errors.UnitError`.

    *name* is the parameter's name, used in every message. A bare number is accepted only when
    *default_unit* is given.
    """
    dim, si_unit = _dimensionality(kind)
    if isinstance(value, pint.Quantity):
        q = value if value._REGISTRY is ureg else Q_(value.magnitude, str(value.units))
    elif isinstance(value, str):
        text = value.strip()
        try:
            q = _parse_text(text)
        except Exception as exc:  # pint raises several types for bad strings
            raise UnitError(f"{name}: cannot read {value!r} as a quantity ({exc})") from None
        if not isinstance(q, pint.Quantity):
            q = Q_(float(q), "")
        if q.dimensionless and default_unit is not None and not _has_unit_text(text):
            q = Q_(q.magnitude, default_unit)
    elif _is_dataarray(value):
        units = value.attrs.get("units")
        if units is None:
            if default_unit is None:
                raise UnitError(f"{name}: DataArray has no 'units' attribute; expected {_dim_text(dim)} (e.g. {si_unit or '1'})")
            units = default_unit
        try:
            q = Q_(np.asarray(value.values, dtype=float), normalise_unit_text(str(units)))
        except Exception as exc:
            raise UnitError(f"{name}: unknown unit {units!r} ({exc})") from None
    else:
        try:
            mag = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{name}: expected a number with units, got {value!r}") from None
        if default_unit is None:
            if dim == ureg.Quantity(1.0).dimensionality:
                default_unit = ""
            else:
                raise UnitError(
                    f"{name}: bare number {value!r} has no unit; give one, e.g. '{_example(value)} {si_unit}' "
                    f"({_dim_text(dim)} expected)"
                )
        q = Q_(mag if mag.ndim else float(mag), default_unit)
    if q.dimensionality != dim and q.dimensionless and isinstance(value, str) and not _has_unit_text(value):
        raise UnitError(f"{name}: {value!r} has no unit; give one, e.g. '{value.strip()} {si_unit}' "
                        f"({_dim_text(dim)} expected)")
    if q.dimensionality != dim:
        raise UnitError(
            f"{name}: unit {format(q.units, '~')!s} has dimension {_dim_text(q.dimensionality)}, "
            f"expected {_dim_text(dim)} (e.g. {si_unit or 'dimensionless'})"
        )
    return q


def to_si(value: Any, *, name: str, kind: str, default_unit: str | None = None,
          finite: bool = True, positive: bool = False, nonnegative: bool = False):
    """Convert *value* to its SI magnitude (float, ndarray, or DataArray with SI ``units`` attr).

    Optional checks raise :class:`~breachflow.errors.InputError` naming *name*: ``finite`` (no NaN/inf),
    ``positive`` (> 0), ``nonnegative`` (>= 0).
    """
    q = parse_quantity(value, name=name, kind=kind, default_unit=default_unit)
    _, si_unit = _dimensionality(kind)
    mag = q.to(si_unit).magnitude if si_unit else q.to("").magnitude
    arr = np.asarray(mag, dtype=float)
    if finite and not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: value is not finite ({value!r})")
    if positive and np.any(arr <= 0):
        raise InputError(f"{name}: must be > 0, got {value!r}")
    if nonnegative and np.any(arr < 0):
        raise InputError(f"{name}: must be >= 0, got {value!r}")
    if _is_dataarray(value):
        out = value.copy(data=arr)
        out.attrs = dict(value.attrs)
        out.attrs["units"] = si_unit or "1"
        return out
    return float(arr) if arr.ndim == 0 else arr


def format_quantity(value: float, si_unit: str, display_unit: str | None = None, digits: int = 3) -> str:
    """Human-readable text of an SI magnitude, optionally converted to *display_unit*."""
    q = Q_(value, si_unit)
    if display_unit:
        q = q.to(display_unit)
    if not math.isfinite(q.magnitude):
        return f"{q.magnitude} {format(q.units, '~')}"
    return f"{q.magnitude:.{digits}g} {format(q.units, '~')}".strip()


def _has_unit_text(text: str) -> bool:
    return any(c.isalpha() and c not in "eE" for c in text) or "%" in text


def _is_dataarray(value) -> bool:
    return type(value).__name__ == "DataArray" and hasattr(value, "attrs")


def _dim_text(dim) -> str:
    text = str(dim)
    return "dimensionless" if text == "dimensionless" else text


def _example(value) -> str:
    try:
        return f"{float(value):g}"
    except (TypeError, ValueError):
        return "1"
