"""Per-cycle figures of closure members in the ensemble result: ``cycle_<name>`` along the ensemble
dimensions and ``cycle``.

A member runner that writes closure runs says where its members' cycle files are (class attribute
``cycle_files``, a glob relative to the member's run directory, e.g. ``"closure/cycle_*.nc"``).
:func:`add_per_cycle` reads every numeric per-cycle variable of those files
(:mod:`breachflow.io.cycle_variables`: breach discharge, gap speeds, masses and mass placed and lost,
criteria, ...) and adds it to the result as ``cycle_<name>`` with dimensions ``(*ensemble dims, cycle)``;
members that stopped earlier (or failed) are filled with NaN / the integer fill value after their last
cycle. These variables carry ``ensemble_per_cycle = "cycle"``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..io.cycle_variables import cycle_coordinate

PER_CYCLE = "ensemble_per_cycle"
PREFIX = "cycle_"


def _member_cycles(run_dir: Path, pattern: str) -> dict[str, np.ndarray] | None:
    files = sorted(run_dir.glob(pattern))
    if not files:
        return None
    out: dict[str, list] = {}
    attrs: dict[str, dict] = {}
    for f in files:
        with xr.open_dataset(f) as ds:
            for name, var in ds.data_vars.items():
                if var.dims == ("cycle",) and np.issubdtype(var.dtype, np.number):
                    out.setdefault(name, []).append(np.asarray(var.values)[0])
                    attrs[name] = {k: v for k, v in var.attrs.items()}
    return {name: (np.asarray(vals), attrs[name]) for name, vals in out.items()}


def add_per_cycle(ds: xr.Dataset, records: list[dict], runner_cls) -> xr.Dataset:
    """*ds* with the per-cycle variables of its members' closure runs (see the module docstring); unchanged
    when the runner declares no ``cycle_files`` or no member wrote any."""
    from .dataset import INT_FILL

    pattern = getattr(runner_cls, "cycle_files", None)
    if not pattern:
        return ds
    dims = tuple(str(ds.attrs["ensemble_dimensions"]).split())
    shape = tuple(ds.sizes[d] for d in dims)
    members = [_member_cycles(Path(r["run_dir"]), pattern) if r.get("status") == "ok" and r.get("run_dir") else None
               for r in records]
    found = [m for m in members if m]
    if not found:
        return ds
    n = max(len(v[0]) for m in found for v in m.values())
    names = sorted({k for m in found for k in m})
    for name in names:
        kind = next(m[name][0].dtype for m in found if name in m)
        attrs = dict(next(m[name][1] for m in found if name in m))
        if np.issubdtype(kind, np.floating):
            arr, enc = np.full((len(records), n), np.nan), {}
        else:
            dtype = np.dtype(kind)
            fill = INT_FILL.get(dtype.str[1:], INT_FILL["i8"])
            arr, enc = np.full((len(records), n), fill, dtype=dtype), {"_FillValue": fill}
            if "flag_values" in attrs:
                attrs["flag_values"] = np.asarray(attrs["flag_values"], dtype=dtype)
        for i, m in enumerate(members):
            if m and name in m:
                vals = m[name][0]
                arr[i, :len(vals)] = vals
        attrs[PER_CYCLE] = "cycle"
        attrs["long_name"] = f"{attrs.get('long_name', name)}, per cycle of the member's closure run"
        var = xr.Variable((*dims, "cycle"), arr.reshape(*shape, n), attrs)
        var.encoding.update(enc)
        ds[PREFIX + name] = var
    return ds.assign_coords(cycle=cycle_coordinate(np.arange(1, n + 1)))
