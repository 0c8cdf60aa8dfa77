"""Readable rich tables of scenario results (values with units, which constraint governs)."""
from __future__ import annotations

import numpy as np
import xarray as xr
from rich.table import Table

from .quantities import GOVERNING_NAMES, display

#: (variable, label, SI unit, display unit) rows of the closure-window table, in Table 2.5 order.
WINDOW_ROWS = [
    ("polder_area", "Area of polder, A_P", "m^2", "ha"),
    ("surge_height", "Height of water at the crest, h_W", "m", "m"),
    ("rise_rate", "Rate of rise, flood source", "m/s", "m/h"),
    ("fall_rate", "Rate of fall, flood source", "m/s", "m/h"),
    ("breach_length", "Breach length, B", "m", "m"),
    ("breach_discharge", "Breach discharge, Q_D", "m^3/s", "m^3/s"),
    ("breach_time", "Breach time from the crest, t_F", "s", "h"),
    ("pump_capacity", "Pump capacity, Q_P", "m^3/s", "m^3/s"),
    ("inundation_depth", "Limiting inundation depth, d_I", "m", "cm"),
    ("polder_rise_rate", "Rate of rise within polder, r_P", "m/s", "m/h"),
    ("balance_time", "Breach balance time, t_Q", "s", "h"),
    ("inundation_time", "Polder inundation time, t_I", "s", "h"),
    ("closure_window", "Breach closure window, t_B", "s", "h"),
    ("depth_at_window_end", "Depth of water at end of window", "m", "cm"),
    ("work_start_delay", "Wind delay before crane work", "s", "h"),
    ("working_time", "Working time left in the window", "s", "h"),
]


def _text(ds: xr.Dataset, var: str, si: str, unit: str) -> str:
    if var not in ds:
        return "—"
    value = float(ds[var])
    if var in ("balance_time",) and not bool(ds["balance_reached"]):
        return "no balance within the flood"
    if var == "inundation_time" and not np.isfinite(value):
        return "never (polder does not rise)"
    if var == "closure_window" and not np.isfinite(value):
        return "no limit within the flood"
    if var == "work_start_delay" and not bool(ds["wind_calm_reached"]):
        return "wind never below the limit"
    digits = 3 if unit not in ("ha",) else 4
    return display(value, si, unit, digits)


def window_table(datasets, names, title="Breach closure window") -> Table:
    """One column per scalar closure-window Dataset (as the report's Table 2.5)."""
    table = Table(title=title, title_justify="left", min_width=len(title))
    table.add_column("variable")
    for n in names:
        table.add_column(n, justify="right")
    for var, label, si, unit in WINDOW_ROWS:
        if not any(var in ds for ds in datasets):
            continue
        cells = [_text(ds, var, si, unit) for ds in datasets]
        if var == "closure_window":
            cells = [f"[bold]{c}[/]" for c in cells]
        table.add_row(label, *cells)
    table.add_row("Governing constraint", *[GOVERNING_NAMES[int(ds["governing"])] for ds in datasets])
    return table


def window_grid_table(ds: xr.Dataset, title="Breach closure window") -> Table:
    """One row per combination of the swept inputs of a vectorised closure-window Dataset."""
    dims = list(ds["closure_window"].dims)
    frame = ds[["balance_time", "inundation_time", "closure_window", "depth_at_window_end", "governing"]].to_dataframe()
    table = Table(title=title, title_justify="left", min_width=len(title))
    units = {"surge_height": ("m", "m"), "fall_rate": ("m/s", "cm/h"), "rise_rate": ("m/s", "cm/h"),
             "polder_area": ("m^2", "ha"), "inundation_depth": ("m", "m"), "breach_length": ("m", "m"),
             "breach_discharge": ("m^3/s", "m^3/s"), "pump_capacity": ("m^3/s", "m^3/s"), "breach_time": ("s", "h")}
    short = {"surge_height": "h_W", "fall_rate": "fall", "rise_rate": "rise", "polder_area": "A_P",
             "inundation_depth": "d_I", "breach_length": "B", "breach_discharge": "Q_D", "pump_capacity": "Q_P",
             "breach_time": "t_F"}
    for d in dims:
        table.add_column(f"{short.get(d, d)} [{units.get(d, ('', ''))[1]}]", justify="right")
    for col in ("t_Q [h]", "t_I [h]", "t_B [h]", "depth [cm]", "gov."):
        table.add_column(col, justify="right")
    for index, row in frame.iterrows():
        index = index if isinstance(index, tuple) else (index,)
        cells = []
        for d, v in zip(dims, index):
            si, unit = units.get(d, ("", ""))
            cells.append(display(float(v), si, unit, 4).rsplit(" ", 1)[0] if si else f"{v}")
        hours = [f"{v / 3600:.1f}" if np.isfinite(v) else "—" for v in
                 (row["balance_time"], row["inundation_time"], row["closure_window"])]
        depth = f"{row['depth_at_window_end'] * 100:.0f}" if np.isfinite(row["depth_at_window_end"]) else "—"
        gov = int(row["governing"])
        hours[2] = f"[bold]{hours[2]}[/]"
        table.add_row(*cells, *hours, depth, ("t_Q", "t_I", "none")[gov])
    return table


def growth_table(growth: xr.DataArray, title="Breach length B (m) vs development time t_D",
                 time_to: xr.DataArray | None = None) -> Table:
    """Rows: equations (number, short title); columns: B at each development time [, t_D to reach a length]."""
    from .growth import growth_equations

    table = Table(title=title, title_justify="left", min_width=len(title))
    table.add_column("eq")
    table.add_column("equation")
    times = np.atleast_1d(growth["development_time"].values) if "development_time" in growth.dims else []
    for t in times:
        table.add_column(f"{t / 3600:g} h", justify="right")
    if time_to is not None:
        table.add_column(f"t_D to {time_to.attrs['target_length_m']:g} m", justify="right")
    eqs = growth["equation"].values if "equation" in growth.dims else [None]
    for eq in eqs:
        row = growth.sel(equation=eq) if eq is not None else growth
        cls = growth_equations.get(eq) if eq is not None else None
        cells = [f"{v:,.0f}" if v >= 100 else f"{v:.1f}" for v in np.atleast_1d(row.values)]
        if time_to is not None:
            v = float(time_to.sel(equation=eq))
            cells.append(f"{v / 3600:.2f} h" if np.isfinite(v) else "> 72 h")
        table.add_row(cls.equation if cls else growth.attrs.get("equation", ""),
                      cls.title if cls else growth.attrs.get("source", ""), *cells)
    if "capped_by" in growth.attrs:
        table.caption = f"capped at {growth.attrs['max_length_m']:.1f} m by {growth.attrs['capped_by']}"
    return table


def max_length_table(max_len: xr.DataArray, title="Maximum breach length") -> Table:
    from .growth import max_length_equations

    table = Table(title=title, title_justify="left", min_width=len(title))
    for col in ("eq", "source", "formula", "B_max"):
        table.add_column(col, justify="right" if col == "B_max" else "left")
    for eq in np.atleast_1d(max_len["equation"].values):
        cls = max_length_equations.get(eq)
        table.add_row(cls.equation, cls.title, cls.formula, f"{float(max_len.sel(equation=eq)):.1f} m")
    return table
