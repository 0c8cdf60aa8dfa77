"""Atomic writers for scenario results (NetCDF, figures): temp file in the target directory + os.replace."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..atomic import atomic_path  # noqa: F401  (re-exported for the scenario writers)


def netcdf_ready(ds: xr.Dataset) -> xr.Dataset:
    """Booleans → int8 flags (CF), string coordinates kept; NaN marks 'not reached' explained by flags."""
    out = ds.copy()
    for name, var in out.variables.items():
        if var.dtype == bool:
            attrs = dict(var.attrs)
            attrs.update(flag_values=np.array([0, 1], dtype="i1"), flag_meanings="false true")
            attrs.pop("units", None)
            out[name] = var.astype("i1")
            out[name].attrs = attrs
    return out


def write_netcdf(ds: xr.Dataset, path) -> Path:
    """Write *ds* to NetCDF atomically (never a half-written file)."""
    path = Path(path)
    if "closure_window" in ds:
        from ..schemas import validate

        validate(ds, "closure_window")
    from ..provenance import stamp

    from ..io.cf import string_encoding

    from ..io.cf import cf_text_coordinates

    ds = cf_text_coordinates(stamp(netcdf_ready(ds)))
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, encoding=string_encoding(ds))
    return path
