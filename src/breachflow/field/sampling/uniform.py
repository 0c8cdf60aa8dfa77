"""A grid snapshot of still or uniform water, for tests and examples."""
from __future__ import annotations

import numpy as np
import xarray as xr

from ...errors import InputError


def uniform_snapshot(depth, u=0.0, v=0.0, bed=0.0, extent=(-50.0, 50.0, -50.0, 50.0), spacing=1.0,
                     **kwargs) -> xr.Dataset:
    """A valid grid snapshot of still / uniform water for tests and examples.

    Cell centres run from ``x0`` to ``x1`` and ``y0`` to ``y1`` (inclusive, *spacing* apart), so the whole
    *extent* is inside the field. Values may carry units (``"2 m"``, ``"1 ft/s"``); bare numbers are SI.
    They may also be arrays broadcastable to ``(ny, nx)``. Extra keyword arguments go to
    :func:`~breachflow.field.snapshot.grid_snapshot`.
    """
    from ...units import to_si
    from ..snapshot import grid_snapshot

    x0, x1, y0, y1 = (to_si(e, name="extent", kind="length", default_unit="m") for e in extent)
    ds_ = to_si(spacing, name="spacing", kind="length", default_unit="m", positive=True)
    dxs, dys = (float(ds_), float(ds_)) if np.ndim(ds_) == 0 else (float(ds_[0]), float(ds_[1]))
    if x1 < x0 or y1 < y0:
        raise InputError(f"extent {extent!r} must be (x0, x1, y0, y1) with x1 >= x0 and y1 >= y0")
    nx = int(round((x1 - x0) / dxs)) + 1
    ny = int(round((y1 - y0) / dys)) + 1
    x = x0 + dxs * np.arange(nx)
    y = y0 + dys * np.arange(ny)
    shape = (ny, nx)
    h = np.broadcast_to(to_si(depth, name="depth", kind="length", default_unit="m", nonnegative=True), shape)
    uu = np.broadcast_to(to_si(u, name="u", kind="speed", default_unit="m/s"), shape)
    vv = np.broadcast_to(to_si(v, name="v", kind="speed", default_unit="m/s"), shape)
    b = np.broadcast_to(to_si(bed, name="bed", kind="length", default_unit="m"), shape)
    kwargs.setdefault("source", "breachflow.field.sampling.uniform_snapshot")
    return grid_snapshot(x, y, b, h, uu, vv, **kwargs)
