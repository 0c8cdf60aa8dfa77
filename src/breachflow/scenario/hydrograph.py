"""Flood-side stage hydrographs: the report's linearised FSSH and measured series (docs/theory.md, *Closure window*; report §2.3–2.4).

Times are seconds relative to the flood crest (negative before it); stages are metres of water above the
local ground at the breach (``h_W`` at the crest).
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError, ParseError
from ..units import Q_, parse_quantity


@dataclass(frozen=True)
class LinearHydrograph:
    """Linearised FSSH: ``z_F(t) = h_W + r_rise t`` before the crest, ``h_W - r_fall t`` after it.

    Stage is floored at the ground (0). ``end_time`` (s after the crest) ends the flood; ``inf`` = none.
    """

    surge_height: float
    rise_rate: float
    fall_rate: float
    end_time: float = np.inf

    def stage(self, t):
        t = np.asarray(t, dtype=float)
        z = np.where(t < 0, self.surge_height + self.rise_rate * t, self.surge_height - self.fall_rate * t)
        return np.maximum(z, 0.0)


@dataclass(frozen=True)
class MeasuredHydrograph:
    """A measured flood-side stage series, re-referenced so that t = 0 is its crest (first maximum).

    ``times`` (s, increasing) and ``stage`` (m above the ground at the breach) are plain arrays; the
    flood ends with the last sample (``end_time``).
    """

    times: np.ndarray
    stage_values: np.ndarray
    crest_offset: float = 0.0  # time of the crest in the caller's original time axis (s)
    source: str = ""

    def __post_init__(self):
        t, z = np.asarray(self.times, float), np.asarray(self.stage_values, float)
        where = self.source or "measured hydrograph"
        if t.ndim != 1 or t.shape != z.shape or t.size < 2:
            raise InputError(f"{where}: needs matching 1-D time and stage arrays with at least 2 samples")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(z))):
            bad = int(np.flatnonzero(~(np.isfinite(t) & np.isfinite(z)))[0])
            raise InputError(f"{where}: sample {bad} is not finite (time {t[bad]}, stage {z[bad]})")
        if np.any(np.diff(t) <= 0):
            bad = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
            raise InputError(f"{where}: times must increase strictly (sample {bad})")

    @property
    def surge_height(self) -> float:
        return float(np.max(self.stage_values))

    @property
    def end_time(self) -> float:
        return float(self.times[-1])

    def stage(self, t):
        return np.interp(np.asarray(t, dtype=float), self.times, np.maximum(self.stage_values, 0.0),
                         left=np.nan, right=np.nan)

    @classmethod
    def from_arrays(cls, times, stage, *, source: str = "", ground_elevation: float = 0.0) -> "MeasuredHydrograph":
        """Build from SI arrays in any time origin; shifts times so the crest (first maximum) is t = 0."""
        t = np.asarray(times, dtype=float)
        z = np.asarray(stage, dtype=float) - ground_elevation
        probe = cls(t, z, source=source)  # validates
        crest = float(probe.times[int(np.argmax(probe.stage_values))])
        return cls(probe.times - crest, probe.stage_values, crest_offset=crest, source=source)

    @classmethod
    def from_dataarray(cls, da: xr.DataArray, *, ground_elevation=None) -> "MeasuredHydrograph":
        """From a 1-D DataArray of stage with a ``units`` attr; its time coordinate is datetime64,
        timedelta64 or numeric with a ``units`` attr (e.g. ``"h"``)."""
        from ..units import to_si

        if da.ndim != 1:
            raise InputError(f"hydrograph: expected a 1-D stage series, got dims {da.dims}")
        stage = np.asarray(to_si(da, name=f"hydrograph {da.name or ''}".strip(), kind="length").values, float)
        coord = da[da.dims[0]]
        times = _times_to_seconds(coord.values, coord.attrs.get("units"), name=f"hydrograph coordinate {coord.name!r}")
        ground = 0.0 if ground_elevation is None else to_si(ground_elevation, name="ground_elevation", kind="length")
        return cls.from_arrays(times, stage, source=str(da.name or "DataArray"), ground_elevation=ground)

    @classmethod
    def from_csv(cls, path, *, ground_elevation=None, column: str | None = None) -> "MeasuredHydrograph":
        """From a CSV file ``time [h], stage [ft]`` (see :func:`~breachflow.scenario.hydrograph.read_series_csv`)."""
        from ..units import to_si

        times, stage, _ = read_series_csv(path, kind="length", column=column)
        ground = 0.0 if ground_elevation is None else to_si(ground_elevation, name="ground_elevation", kind="length")
        return cls.from_arrays(times, stage, source=str(path), ground_elevation=ground)


def first_crossing(t, g) -> float:
    """First time at which the piecewise-linear g(t) reaches zero from above; NaN if it never does.

    Exact for piecewise-linear data: the root is interpolated inside the first interval whose end value is
    <= 0. If ``g[0] <= 0`` the crossing is ``t[0]``. Later re-crossings (noise) do not matter.
    """
    t = np.asarray(t, dtype=float)
    g = np.asarray(g, dtype=float)
    hits = np.flatnonzero(g <= 0.0)
    if hits.size == 0:
        return float("nan")
    i = int(hits[0])
    if i == 0:
        return float(t[0])
    g0, g1 = g[i - 1], g[i]
    return float(t[i - 1] + (t[i] - t[i - 1]) * g0 / (g0 - g1))


def measured_balance_time(times, stage, polder_rate: float, breach_time: float) -> float:
    """Breach balance instant (s from crest) for a measured FSSH and the polder line r_P (t - t_0).

    The nodes are the samples after the breach plus the breach instant itself, so the difference of the
    two piecewise-linear curves is linear between nodes and :func:`first_crossing` is exact.
    NaN when the curves do not meet before the record ends.
    """
    times = np.asarray(times, float)
    if breach_time < times[0] or breach_time >= times[-1]:
        raise InputError(f"breach_time {breach_time / 3600:.3g} h is outside the measured hydrograph "
                         f"({times[0] / 3600:.3g} h to {times[-1] / 3600:.3g} h from the crest)")
    later = times > breach_time
    nodes = np.concatenate([[breach_time], times[later]])
    z_f = np.maximum(np.concatenate([[np.interp(breach_time, times, stage)], np.asarray(stage, float)[later]]), 0.0)
    if z_f[0] <= 0:
        raise InputError(f"breach_time {breach_time / 3600:.3g} h: the flood stage is not above the ground then")
    z_p = max(polder_rate, 0.0) * (nodes - breach_time)
    return first_crossing(nodes, z_f - z_p)


_HEADER = re.compile(r"^\s*([^\[\(]+?)\s*(?:[\[\(]\s*(.*?)\s*[\]\)])?\s*$")


def read_series_csv(path, *, kind: str, column: str | None = None):
    """Read a two-column time series with units in the header: ``time [h], stage [ft]``.

    Lines starting with ``#`` are comments. The time column is numeric with a unit, or ISO-8601
    date-times (no unit). With more than two columns, *column* picks the value column by name.
    Returns ``(times_s, values_si, is_datetime)``; times are seconds in the file's own origin (or since
    1970-01-01 for date-times). Errors name the file and line.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(text.splitlines()))
            if r and not r[0].lstrip().startswith("#") and any(c.strip() for c in r)]
    if len(rows) < 3:
        raise ParseError("needs a header line and at least two data lines", path=path, line=None)
    head_line, header = rows[0]
    parsed = [_HEADER.match(h) for h in header]
    names = [m.group(1).strip().lower() if m else h for m, h in zip(parsed, header)]
    units = [m.group(2) if m else None for m in parsed]
    if column is None:
        if len(header) != 2:
            raise ParseError(f"expected 2 columns (time, value), found {len(header)}; choose one with column=",
                             path=path, line=head_line)
        vcol = 1
    else:
        if column.lower() not in names:
            raise ParseError(f"no column {column!r}; columns: {names}", path=path, line=head_line)
        vcol = names.index(column.lower())
    vunit = units[vcol]
    if not vunit:
        raise ParseError(f"column {names[vcol]!r} has no unit; write it as '{names[vcol]} [unit]'", path=path, line=head_line)
    scale = _unit_scale(vunit, kind, f"column {names[vcol]!r}", path, head_line)
    tunit = units[0]
    if tunit:
        tscale = _unit_scale(tunit, "time", f"column {names[0]!r}", path, head_line)
    times, values = [], []
    for line, row in rows[1:]:
        row = [c.strip() for c in row]
        if len(row) != len(header):
            raise ParseError(f"expected {len(header)} fields, found {len(row)}", path=path, line=line)
        try:
            value = float(row[vcol])
        except ValueError:
            raise ParseError(f"{names[vcol]}: {row[vcol]!r} is not a number", path=path, line=line) from None
        if not np.isfinite(value):
            raise ParseError(f"{names[vcol]}: {row[vcol]!r} is not finite", path=path, line=line)
        cell = row[0].strip()
        if tunit:
            try:
                tval = float(cell) * tscale[0]
            except ValueError:
                raise ParseError(f"{names[0]}: {cell!r} is not a number", path=path, line=line) from None
        else:
            try:
                tval = np.datetime64(cell, "s").astype("int64").astype(float)
            except ValueError:
                raise ParseError(f"{names[0]}: {cell!r} is neither a number (add a unit to the header) "
                                 "nor an ISO date-time", path=path, line=line) from None
        if times and tval <= times[-1]:
            raise ParseError(f"{names[0]}: times must increase strictly", path=path, line=line)
        times.append(tval)
        values.append(value * scale[0] + scale[1])
    return np.asarray(times), np.asarray(values), not tunit


def _unit_scale(unit: str, kind: str, what: str, path, line):
    from ..errors import UnitError

    try:
        one = parse_quantity(f"1 {unit}", name=what, kind=kind)
        zero = parse_quantity(f"0 {unit}", name=what, kind=kind)
    except UnitError as exc:
        raise ParseError(str(exc), path=path, line=line) from None
    from ..units import SI_UNITS

    si = SI_UNITS.get(kind, kind)
    offset = zero.to(si).magnitude
    return (one.to(si).magnitude - offset, offset)


def _times_to_seconds(values, units, *, name: str) -> np.ndarray:
    values = np.asarray(values)
    if np.issubdtype(values.dtype, np.datetime64):
        return (values - values[0]).astype("timedelta64[ns]").astype("int64") / 1e9
    if np.issubdtype(values.dtype, np.timedelta64):
        return values.astype("timedelta64[ns]").astype("int64") / 1e9
    if units is None:
        raise InputError(f"{name}: numeric times need a 'units' attribute (e.g. 'h')")
    return np.asarray(Q_(values.astype(float), units).to("s").magnitude, float)
