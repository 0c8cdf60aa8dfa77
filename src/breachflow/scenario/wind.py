"""Wind constraint on the start of closure work (docs/theory.md, *Closure window*; report §2.4, Fig 2.8).

Land cranes stop at about 13 m/s of wind, ship cranes at about 25 m/s (Watson 2004). Work can start at
the first instant after the breach at which the wind speed is at or below the crane's limit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from ..errors import InputError
from ..units import to_si
from .hydrograph import _times_to_seconds, first_crossing, read_series_csv

#: Crane operating limits of the report [2.4] (m/s).
CRANE_WIND_LIMITS = {"land": 13.0, "ship": 25.0}


@dataclass(frozen=True)
class WindRecord:
    """Wind speed (m/s) at times (s) relative to the flood crest."""

    times: np.ndarray
    speed: np.ndarray
    source: str = ""

    def __post_init__(self):
        t, v = np.asarray(self.times, float), np.asarray(self.speed, float)
        where = self.source or "wind record"
        if t.ndim != 1 or t.shape != v.shape or t.size < 1:
            raise InputError(f"{where}: needs matching 1-D time and speed arrays")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise InputError(f"{where}: contains non-finite values")
        if np.any(v < 0):
            raise InputError(f"{where}: wind speed must be >= 0")
        if np.any(np.diff(t) <= 0):
            raise InputError(f"{where}: times must increase strictly")

    @classmethod
    def from_csv(cls, path, *, crest_time=None, column: str | None = None) -> "WindRecord":
        """``time [h], speed [mph]`` relative to the crest, or ISO date-times with *crest_time* given."""
        times, speed, is_datetime = read_series_csv(path, kind="speed", column=column)
        if is_datetime:
            if crest_time is None:
                raise InputError(f"{path}: date-time wind records need crest_time (the flood crest's date-time)")
            times = times - np.datetime64(str(crest_time), "s").astype("int64").astype(float)
        return cls(times, speed, source=str(path))

    @classmethod
    def from_dataarray(cls, da: xr.DataArray, *, crest_time=None) -> "WindRecord":
        speed = np.asarray(to_si(da, name="wind speed", kind="speed").values, float)
        coord = da[da.dims[0]]
        vals = np.asarray(coord.values)
        if np.issubdtype(vals.dtype, np.datetime64):
            if crest_time is None:
                raise InputError("wind: date-time coordinates need crest_time")
            times = (vals - np.datetime64(crest_time)).astype("timedelta64[ns]").astype("int64") / 1e9
        else:
            times = _times_to_seconds(vals, coord.attrs.get("units"), name="wind time coordinate")
        return cls(times, speed, source=str(da.name or "wind DataArray"))


def work_start_time(record: WindRecord, limit: float, breach_time: float) -> float:
    """First instant (s from crest) at or after the breach with wind <= *limit*; NaN if never in the record."""
    t, v = np.asarray(record.times, float), np.asarray(record.speed, float)
    if breach_time < t[0] or breach_time > t[-1]:
        raise InputError(f"wind record ({t[0] / 3600:.3g} h to {t[-1] / 3600:.3g} h from the crest) does not "
                         f"cover the breach time {breach_time / 3600:.3g} h")
    later = t > breach_time
    nodes = np.concatenate([[breach_time], t[later]])
    speed = np.concatenate([[np.interp(breach_time, t, v)], v[later]])
    return first_crossing(nodes, speed - limit)


def crane_limit(value) -> float:
    """A wind limit from ``"land"``/``"ship"`` or a speed with units."""
    if isinstance(value, str) and value.strip().lower() in CRANE_WIND_LIMITS:
        return CRANE_WIND_LIMITS[value.strip().lower()]
    return to_si(value, name="wind_limit", kind="speed", positive=True)
