"""A closure run's own files as hydrodynamic snapshots, for the commands that take a snapshot.

A cycle file (``RUN/cycle_NNNN.nc``) and a ``breachflow combine`` archive hold the grid of one or more
cycles along the dimension ``cycle``, with the particles and the per-cycle figures next to it.
:func:`read_grid_file` turns such a file into the snapshot of one cycle (by default the last one in the
file): the grid variables of that cycle, without the ``cycle`` dimension, the particles or the per-cycle
scalars, checked against the snapshot schema — so ``breachflow inspect`` and ``breachflow export``
take a run's files as they take ``solve`` and ``ingest`` output. Any other file is read with
:func:`breachflow.field.snapshot.read_snapshot`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError


def is_run_file(ds: xr.Dataset) -> bool:
    """Whether *ds* is a cycle file or a combine archive (its grid has a ``cycle`` dimension)."""
    return "cycle" in ds.dims and "depth" in ds and "cycle" in ds["depth"].dims


def cycle_snapshot(ds: xr.Dataset, cycle: int | None = None, *, source: str = "") -> xr.Dataset:
    """The snapshot of cycle *cycle* (None: the last one) of run-file Dataset *ds* (not validated)."""
    cycles = [int(c) for c in np.atleast_1d(ds["cycle"].values)]
    if cycle is None:
        one = ds.isel(cycle=-1)
    elif cycle in cycles:
        one = ds.isel(cycle=cycles.index(cycle))
    else:
        raise InputError(f"{source or 'run file'}: no cycle {cycle}; it holds cycle(s) "
                         f"{', '.join(map(str, cycles))}")
    g = cycles[-1] if cycle is None else cycle
    keep = [v for v in one.data_vars
            if v == "crs" or (one[v].ndim and "particle" not in one[v].dims)]
    snap = one[keep].drop_vars(["cycle", "particle"], errors="ignore")
    snap = snap.drop_dims([d for d in snap.dims if d not in {dd for v in snap.variables.values() for dd in v.dims}],
                          errors="ignore")
    snap.attrs = dict(ds.attrs)
    snap.attrs["title"] = f"{ds.attrs.get('title', 'breachflow closure run')}, cycle {g}"
    snap.attrs["closure_cycle"] = np.int32(g)
    return snap


def read_grid_file(path, cycle: int | None = None) -> xr.Dataset:
    """Read *path* as a snapshot: a run's cycle file or combine archive gives the grid of *cycle* (None:
    the last one in the file; :func:`cycle_snapshot`), any other file goes to
    :func:`~breachflow.field.snapshot.read_snapshot`. Validated against the snapshot schema."""
    from ..field.snapshot import read_snapshot, validate_snapshot

    path = Path(path)
    if not path.exists():
        raise InputError(f"snapshot file {str(path)!r} does not exist")
    try:
        with xr.open_dataset(path, engine="netcdf4") as f:
            run_file = is_run_file(f)
            ds = f.load() if run_file else None
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read as NetCDF ({exc})") from None
    if not run_file:
        if cycle is not None:
            raise InputError(f"{path}: --cycle selects a cycle of a run's file; this snapshot has no cycle dimension")
        return read_snapshot(path)
    return validate_snapshot(cycle_snapshot(ds, cycle, source=str(path)), source=str(path))
