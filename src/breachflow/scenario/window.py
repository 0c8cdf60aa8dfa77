"""Breach closure window from stage hydrographs (docs/theory.md, *Closure window*; report §2.3–2.4, Tables 2.5–2.6, Fig 2.6).

Times relative to the flood crest; the breach happens at ``t_0`` (``breach_time``; 0 in the report).

* flood side: ``z_F(t) = h_W + r_rise t`` (t < 0), ``h_W - r_fall t`` (t >= 0), or a measured series;
* polder: ``r_P = (Q_D - Q_P) / A_P`` and ``z_P(t) = max(r_P, 0) (t - t_0)`` (flat polder, no lag);
* breach balance ``t_Q``: first ``z_F = z_P`` after the breach; for ``t_0 = 0``: ``t_Q = h_W / (r_fall + r_P)``;
* polder inundation ``t_I = d_I / r_P``; closure window ``t_B = min(t_Q, t_I)``; depth ``r_P t_B``.

``t_Q``, ``t_I`` and ``t_B`` are durations from the breach (the report's definition; with ``t_0 = 0``
they equal the crest-referenced times of Table 2.5). A balance later than the end of the flood is "no
balance within the flood": the Dataset says so in ``balance_reached`` and ``governing`` rather than
with a bare NaN or inf.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .hydrograph import LinearHydrograph, MeasuredHydrograph, measured_balance_time
from .presets import FloodPreset, flood_preset
from .quantities import ATTRS, as_dataarray, si_input
from .wind import WindRecord, crane_limit, work_start_time

GOVERNING_BALANCE, GOVERNING_INUNDATION, GOVERNING_NONE = 0, 1, 2


def closure_window(
    *,
    polder_area,
    inundation_depth,
    surge_height=None,
    fall_rate=None,
    rise_rate=None,
    preset: str | FloodPreset | None = None,
    hydrograph=None,
    breach_discharge=None,
    breach_length=None,
    mean_velocity=None,
    pump_capacity="0 m^3/s",
    breach_time="0 h",
    flood_duration=None,
    wind=None,
    wind_limit=None,
) -> xr.Dataset:
    """Closure window for linearised or measured hydrographs, broadcast over every DataArray input.

    Quantities are strings with units (``"2.8 m"``, ``"40 cm/hr"``, ``"800 ha"``, ``"7060 cfs"``), pint
    Quantities, DataArrays with a ``units`` attr (their dimensions broadcast), or lists (a new dimension
    named after the parameter).

    Flood: ``surge_height`` h_W + ``fall_rate`` (+ ``rise_rate``, default = fall rate), or ``preset``
    (a name of :func:`~breachflow.scenario.presets.flood_preset`; explicit values override it), or ``hydrograph`` (a
    :class:`~breachflow.scenario.hydrograph.MeasuredHydrograph`, a stage DataArray, or a CSV path ``time [h], stage [m]``).
    ``flood_duration``: how long after the crest the flood lasts (default: unbounded / end of record).
    Breach: ``breach_discharge`` Q_D, or ``breach_length`` B with ``mean_velocity`` v (default 3 m/s):
    ``Q_D = h_W B v``. ``pump_capacity`` Q_P. ``breach_time``: breaching relative to the crest.
    Wind: ``wind`` (a :class:`~breachflow.scenario.wind.WindRecord`, DataArray or CSV path, times relative to the crest) and
    ``wind_limit`` (speed, or ``"land"`` 13 m/s / ``"ship"`` 25 m/s; default land).
    """
    measured = _measured(hydrograph)
    if measured is not None:
        if any(v is not None for v in (surge_height, fall_rate, rise_rate, preset)):
            raise InputError("hydrograph: give either a measured hydrograph or surge_height/fall_rate/rise_rate/preset")
        h = measured.surge_height
        rf = rr = None
        end = measured.end_time
    else:
        h, rr, rf = _linear_flood(surge_height, fall_rate, rise_rate, preset)
        end = np.inf
    if flood_duration is not None:
        end = np.minimum(end, si_input(flood_duration, name="flood_duration", kind="time", positive=True))
    area = si_input(polder_area, name="polder_area", kind="area", positive=True)
    depth_limit = si_input(inundation_depth, name="inundation_depth", kind="length", positive=True)
    q_d = _discharge(h, breach_discharge, breach_length, mean_velocity)
    q_p = si_input(pump_capacity, name="pump_capacity", kind="discharge", nonnegative=True)
    t0 = si_input(breach_time, name="breach_time", kind="time")

    rate = (q_d - q_p) / area  # r_P, may be <= 0 when pumps match the inflow
    rate_up = np.maximum(rate, 0.0)

    if measured is None:
        stage0 = xr.where(_da(t0) < 0, _da(h) + _da(rr) * t0, _da(h) - _da(rf) * t0)
        if bool(np.any(np.asarray(stage0) <= 0)):
            raise InputError("breach_time: the flood stage at the breach is not above the ground "
                             "(the breach must happen while the water stands above the local ground)")
        balance_abs = _linear_balance(h, rr, rf, rate_up, t0)
    else:
        balance_abs = xr.apply_ufunc(
            lambda r, t: measured_balance_time(measured.times, measured.stage_values, r, t),
            _da(rate_up), _da(t0), vectorize=True)
    if bool(np.any(np.asarray(_da(t0) >= end))):
        raise InputError("breach_time: the breach happens after the end of the flood")

    balance_ok = np.isfinite(balance_abs) & (balance_abs <= end)
    balance_time = xr.where(balance_ok, balance_abs - t0, np.nan)
    inundation_time = xr.where(_da(rate_up) > 0, depth_limit / xr.where(_da(rate_up) > 0, rate_up, 1.0), np.nan)
    inundation_in_flood = np.isfinite(inundation_time) & (inundation_time + t0 <= end)
    tq = balance_time.fillna(np.inf)
    ti = xr.where(inundation_in_flood, inundation_time, np.inf)
    window = np.minimum(tq, ti)
    governing = xr.where(np.isinf(window), GOVERNING_NONE,
                         xr.where(tq <= ti, GOVERNING_BALANCE, GOVERNING_INUNDATION)).astype("i1")
    window = xr.where(np.isinf(window), np.nan, window)
    inundation_reached = inundation_in_flood & (ti <= tq)

    out = {
        "surge_height": h, "polder_area": area, "inundation_depth": depth_limit, "breach_discharge": q_d,
        "pump_capacity": q_p, "breach_time": t0, "polder_rise_rate": rate,
        "balance_time": balance_time, "inundation_time": inundation_time, "closure_window": window,
        "depth_at_window_end": rate_up * window, "balance_reached": balance_ok,
        "inundation_reached": inundation_reached, "governing": governing,
    }
    if measured is None:
        out.update(rise_rate=rr, fall_rate=rf)
    if np.any(np.isfinite(np.asarray(end))):
        out["flood_end_time"] = end
    if breach_length is not None:
        out["breach_length"] = si_input(breach_length, name="breach_length", kind="length", positive=True)
        out["mean_velocity"] = si_input(mean_velocity or "3 m/s", name="mean_velocity", kind="speed", positive=True)
    if wind is not None:
        out.update(_wind(wind, wind_limit, t0, window))
    ds = xr.Dataset({k: (v if k == "wind_speed" else as_dataarray(v, k)) for k, v in out.items()})
    for k in ("balance_reached", "inundation_reached", "wind_calm_reached"):
        if k in ds:
            ds[k] = ds[k].astype(bool)
            ds[k].attrs = dict(ATTRS[k])
    for name in ds.coords:  # dimension coordinates lose the attributes of the inputs when broadcast
        if name in ATTRS and not ds[name].attrs.get("units"):
            ds[name].attrs.update(ATTRS[name])
    ds.attrs = {
        "title": "Breach closure window",
        "Conventions": "CF-1.8",
        "method": ("measured flood-side hydrograph, first crossing of the polder stage" if measured is not None
                   else "linearised stage hydrographs") + " (docs/theory.md, *Closure window*; SERRI 70015-001 §2.4)",
        "references": "SERRI Report 70015-001 (2009), Tables 2.5-2.6, Fig. 2.6",
    }
    if measured is not None:
        ds = ds.assign_coords(hydrograph_time=("hydrograph_time", measured.times,
                                               {"units": "s", "long_name": "time relative to the flood crest"}))
        ds["hydrograph_stage"] = ("hydrograph_time", measured.stage_values,
                                  {"units": "m", "long_name": "measured flood-side stage above the ground at the breach"})
        ds.attrs["hydrograph_source"] = measured.source
    if isinstance(preset, FloodPreset) or isinstance(preset, str):
        p = preset if isinstance(preset, FloodPreset) else flood_preset(preset)
        ds.attrs["flood_preset"] = f"{p.key}: {p.event} ({p.source})"
    return ds


def _da(x):
    return x if isinstance(x, xr.DataArray) else xr.DataArray(x)


def _linear_flood(surge_height, fall_rate, rise_rate, preset):
    p = None
    if preset is not None:
        p = preset if isinstance(preset, FloodPreset) else flood_preset(preset)
    if surge_height is None:
        if p is None or p.surge_height is None:
            raise InputError("surge_height: required (h_W, the flood-side water height above ground at the breach)"
                             + (f"; preset {p.key!r} gives none" if p is not None else ""))
        surge_height = f"{p.surge_height} m"
    if fall_rate is None:
        if p is None:
            raise InputError("fall_rate: required (or a preset / measured hydrograph)")
        fall_rate = f"{p.fall_rate} m/s"
    h = si_input(surge_height, name="surge_height", kind="length", positive=True)
    rf = si_input(fall_rate, name="fall_rate", kind="rate", nonnegative=True)
    if rise_rate is None and p is not None:
        rise_rate = f"{p.rise_rate} m/s"
    # symmetric hydrograph (the report's model problem) when no rise rate is known
    rr = rf if rise_rate is None else si_input(rise_rate, name="rise_rate", kind="rate", nonnegative=True)
    return h, rr, rf


def _linear_balance(h, rr, rf, rate_up, t0):
    """Crest-referenced instant where the linear FSSH meets the polder line; inf if never."""
    h, rr, rf, rate_up, t0 = (_da(v) for v in (h, rr, rf, rate_up, t0))
    # rising limb [t0, 0): the polder overtakes the still-rising flood (only if r_P > r_rise)
    stage0 = h + rr * t0
    on_rise = (t0 < 0) & (h + rate_up * t0 <= 0)
    t_rise = t0 + stage0 / xr.where(rate_up - rr > 0, rate_up - rr, 1.0)
    # falling limb from max(t0, 0)
    ts = np.maximum(t0, 0.0)
    gap = (h - rf * ts) - rate_up * (ts - t0)
    closing = rf + rate_up
    t_fall = xr.where(closing > 0, ts + gap / xr.where(closing > 0, closing, 1.0), np.inf)
    return xr.where(on_rise, t_rise, t_fall)


def _discharge(h, breach_discharge, breach_length, mean_velocity):
    if breach_discharge is not None:
        if breach_length is not None:
            raise InputError("breach_discharge: give either breach_discharge or breach_length (with mean_velocity), not both")
        return si_input(breach_discharge, name="breach_discharge", kind="discharge", positive=True)
    if breach_length is None:
        raise InputError("breach_discharge: required (or breach_length with mean_velocity, Q_D = h_W B v)")
    b = si_input(breach_length, name="breach_length", kind="length", positive=True)
    v = si_input(mean_velocity or "3 m/s", name="mean_velocity", kind="speed", positive=True)
    return h * b * v


def _measured(hydrograph):
    if hydrograph is None or isinstance(hydrograph, MeasuredHydrograph):
        return hydrograph
    if isinstance(hydrograph, LinearHydrograph):
        raise InputError("hydrograph: pass a LinearHydrograph's values as surge_height/fall_rate/rise_rate")
    if isinstance(hydrograph, xr.DataArray):
        return MeasuredHydrograph.from_dataarray(hydrograph)
    if isinstance(hydrograph, (str, Path)):
        return MeasuredHydrograph.from_csv(hydrograph)
    raise InputError(f"hydrograph: expected a MeasuredHydrograph, DataArray or CSV path, got {type(hydrograph).__name__}")


def _wind(wind, wind_limit, t0, window):
    if isinstance(wind, WindRecord):
        record = wind
    elif isinstance(wind, xr.DataArray):
        record = WindRecord.from_dataarray(wind)
    elif isinstance(wind, (str, Path)):
        record = WindRecord.from_csv(wind)
    else:
        raise InputError(f"wind: expected a WindRecord, DataArray or CSV path, got {type(wind).__name__}")
    if isinstance(wind_limit, (list, tuple)):
        limit = xr.DataArray([crane_limit(v) for v in wind_limit], dims="wind_limit")
    elif isinstance(wind_limit, xr.DataArray):
        limit = si_input(wind_limit, name="wind_limit", kind="speed", positive=True)
    else:
        limit = crane_limit("land" if wind_limit is None else wind_limit)
    start = xr.apply_ufunc(lambda lim, t: work_start_time(record, lim, t), _da(limit), _da(t0), vectorize=True)
    calm = np.isfinite(start)
    delay = xr.where(calm, start - t0, np.nan)
    working = xr.where(calm & np.isfinite(window), np.maximum(window - delay, 0.0), np.nan)
    return {"wind_limit": limit, "work_start_delay": delay, "working_time": working, "wind_calm_reached": calm,
            "wind_speed": xr.DataArray(record.speed, dims="wind_time", coords={"wind_time": ("wind_time", record.times, {
                "units": "s", "long_name": "wind record time relative to the flood crest"})},
                attrs={"units": "m/s", "long_name": "wind speed at the breach site"})}
