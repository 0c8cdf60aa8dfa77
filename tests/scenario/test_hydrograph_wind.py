"""Measured hydrographs (robust first crossing), CSV series with units, and the wind delay."""
import numpy as np
import pytest
import xarray as xr

from breachflow import InputError, ParseError
from breachflow.scenario import MeasuredHydrograph, WindRecord, closure_window, first_crossing

H = 3600.0
POLDER = dict(polder_area="800 ha", inundation_depth="90 cm", breach_discharge="200 m^3/s")


def test_first_crossing_is_exact_for_piecewise_linear_data():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    assert first_crossing(t, [2.0, 1.0, -1.0, 5.0]) == pytest.approx(1.5)
    assert first_crossing(t, [0.0, 1.0, 1.0, 1.0]) == 0.0
    assert np.isnan(first_crossing(t, [1.0, 2.0, 3.0, 4.0]))
    assert first_crossing(t, [3.0, 0.0, -1.0, 1.0]) == 1.0  # touching zero counts


def _triangle(times_h, peak=2.8, rate=0.4, crest=5.0):
    return np.maximum(peak - rate * np.abs(np.asarray(times_h) - crest), 0.0)


def test_measured_hydrograph_matches_the_linear_one_and_ignores_later_noise():
    linear = closure_window(surge_height="2.8 m", fall_rate="0.4 m/hr", **POLDER)
    times_h = np.arange(0.0, 20.01, 0.5)  # crest at 5 h in the record's own clock
    stage_ft = _triangle(times_h) / 0.3048
    da = xr.DataArray(stage_ft, dims="time", coords={"time": ("time", times_h, {"units": "h"})},
                      attrs={"units": "ft"}, name="stage")
    ds = closure_window(hydrograph=da, **POLDER)
    assert float(ds.balance_time) == pytest.approx(float(linear.balance_time), rel=1e-9)
    assert float(ds.closure_window) == pytest.approx(float(linear.closure_window), rel=1e-9)
    assert ds.hydrograph_stage.attrs["units"] == "m" and float(ds.hydrograph_time[0]) == -5 * H
    # noise after the first crossing (a second hump) must not move the result
    noisy = stage_ft.copy()
    noisy[times_h > 11] += 3.0 * np.abs(np.sin(times_h[times_h > 11]))
    ds2 = closure_window(hydrograph=da.copy(data=noisy), **POLDER)
    assert float(ds2.balance_time) == pytest.approx(float(linear.balance_time), rel=1e-9)


def test_measured_hydrograph_from_csv_and_end_of_record(tmp_path):
    times_h = np.arange(-4.0, 8.01, 1.0)
    path = tmp_path / "stage.csv"
    lines = ["# gauge near the breach", "time [h], stage [m]"] + [f"{t}, {z}" for t, z in zip(times_h, _triangle(times_h, crest=0.0))]
    path.write_text("\n".join(lines) + "\n")
    ds = closure_window(hydrograph=str(path), **POLDER)
    assert float(ds.balance_time) / H == pytest.approx(2.8 / 0.49, rel=1e-9)
    # record ends before the stages meet: explicit "no balance within the flood"
    short = tmp_path / "short.csv"
    short.write_text("\n".join(lines[:2 + 8]) + "\n")  # up to +3 h
    ds = closure_window(hydrograph=short, polder_area="8000 ha", inundation_depth="90 cm", breach_discharge="200 m^3/s")
    assert not bool(ds.balance_reached) and int(ds.governing) == 2


def test_csv_errors_name_file_and_line(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time [h], stage [m]\n0, 1.0\n1, oops\n")
    with pytest.raises(ParseError, match=r"bad.csv:3: stage: 'oops' is not a number"):
        MeasuredHydrograph.from_csv(p)
    p.write_text("time [h], stage [m/s]\n0, 1.0\n1, 2\n")
    with pytest.raises(ParseError, match=r"bad.csv:1:.*\[length\]"):
        MeasuredHydrograph.from_csv(p)
    p.write_text("time [h], stage [m]\n0, 1.0\n0, 2\n1, 2\n")
    with pytest.raises(ParseError, match=r"bad.csv:3: time: times must increase"):
        MeasuredHydrograph.from_csv(p)
    p.write_text("time [h], stage\n0, 1.0\n1, 2\n")
    with pytest.raises(ParseError, match="has no unit"):
        MeasuredHydrograph.from_csv(p)
    with pytest.raises(InputError, match="not finite"):
        MeasuredHydrograph.from_arrays([0.0, 1.0, 2.0], [1.0, np.nan, 0.5])


def test_iso_datetime_hydrograph(tmp_path):
    p = tmp_path / "iso.csv"
    rows = ["time, stage [m]"]
    for k, z in enumerate([1.2, 2.0, 2.8, 2.4, 2.0, 1.6, 1.2, 0.8, 0.4, 0.0]):
        rows.append(f"2005-08-29T{k:02d}:00, {z}")
    p.write_text("\n".join(rows) + "\n")
    hyd = MeasuredHydrograph.from_csv(p)
    assert hyd.surge_height == 2.8 and hyd.times[2] == 0.0 and hyd.end_time == 7 * H
    ds = closure_window(hydrograph=hyd, **POLDER)
    assert float(ds.balance_time) / H == pytest.approx(2.8 / 0.49, rel=1e-9)


def test_wind_delays_the_start_of_work():
    # 30 m/s at the crest dropping linearly to 0 at +10 h: 13 m/s reached at 17/3 h, 25 m/s at 5/3 h
    wind = WindRecord(np.array([-5.0, 0.0, 10.0, 20.0]) * H, np.array([30.0, 30.0, 0.0, 0.0]))
    ds = closure_window(surge_height="2.8 m", fall_rate="0.06 m/hr", wind=wind, wind_limit=["land", "ship", "35 m/s"],
                        **POLDER)
    np.testing.assert_allclose(ds.work_start_delay.values / H, [17 / 3, 5 / 3, 0.0], rtol=1e-12)
    np.testing.assert_allclose(ds.working_time.values / H, [10 - 17 / 3, 10 - 5 / 3, 10.0], rtol=1e-12)
    # hurricane window (5.7 h) is over before land cranes may work
    ds = closure_window(surge_height="2.8 m", fall_rate="0.4 m/hr", wind=wind, wind_limit="land", **POLDER)
    assert float(ds.working_time) == pytest.approx(max(2.8 / 0.49 - 17 / 3, 0.0) * H, rel=1e-9)
    calm_never = WindRecord(np.array([0.0, 10.0]) * H, np.array([30.0, 20.0]))
    ds = closure_window(surge_height="2.8 m", fall_rate="0.4 m/hr", wind=calm_never, **POLDER)
    assert not bool(ds.wind_calm_reached)
