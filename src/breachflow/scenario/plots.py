"""Figures people look at: the closure-window chart (report Fig 2.6) and breach growth curves (Fig 2.15)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .geometry import LeveeGeometry
from .io import atomic_path
from .quantities import GOVERNING_NAMES

HOUR = 3600.0


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _scalar(ds: xr.Dataset, var: str) -> float:
    return float(ds[var]) if var in ds else float("nan")


def draw_window(ax, ds: xr.Dataset, title: str | None = None) -> None:
    """Fig 2.6 panel on *ax*: FSSH, PSSH, d_I, t_Q and t_I, the closure window shaded."""
    if ds["closure_window"].ndim:
        raise InputError(f"window chart needs one scenario; select along {ds['closure_window'].dims} first")
    h_w, t0 = _scalar(ds, "surge_height"), _scalar(ds, "breach_time") / HOUR
    r_p = max(_scalar(ds, "polder_rise_rate"), 0.0) * HOUR
    d_i = _scalar(ds, "inundation_depth")
    t_q, t_i, t_b = (_scalar(ds, v) / HOUR for v in ("balance_time", "inundation_time", "closure_window"))
    measured = "hydrograph_stage" in ds
    candidates = [v for v in (t_q, t_i, t_b) if np.isfinite(v)]
    t_max = max(30.0, 1.25 * (t0 + max(candidates))) if candidates else 30.0
    if measured:
        t_max = min(t_max, float(ds["hydrograph_time"].max()) / HOUR)
    t_min = min(-12.0, t0 - 3.0)
    if measured:
        t_min = max(t_min, float(ds["hydrograph_time"].min()) / HOUR)
    t = np.linspace(t_min, t_max, 1201)
    if measured:
        ft = np.interp(t, ds["hydrograph_time"].values / HOUR, np.maximum(ds["hydrograph_stage"].values, 0.0))
    else:
        rr, rf = _scalar(ds, "rise_rate") * HOUR, _scalar(ds, "fall_rate") * HOUR
        ft = np.maximum(np.where(t < 0, h_w + rr * t, h_w - rf * t), 0.0)
    ax.plot(t, ft, color="tab:blue", lw=2.2, label="flood-side stage (FSSH)")
    # polder stage: rises from the breach until the balance, later the flow reverses (dotted)
    t_end_rise = t0 + (t_q if np.isfinite(t_q) else t_max - t0)
    tp = np.linspace(t0, t_end_rise, 200)
    ax.plot(tp, r_p * (tp - t0), color="tab:purple", lw=2.2, label=f"polder stage (PSSH), +{r_p:.3g} m/h")
    if np.isfinite(t_q) and t_end_rise < t_max:
        tp2 = np.linspace(t_end_rise, t_max, 50)
        ax.plot(tp2, r_p * (tp2 - t0), color="tab:purple", lw=1.0, ls=":", label="PSSH if inflow continued")
    ax.axhline(d_i, color="tab:green", ls="--", lw=1.2, label=f"permissible inundation d_I = {d_i:.2g} m")
    if np.isfinite(t_b):
        ax.axvspan(t0, t0 + t_b, color="gold", alpha=0.25, label=f"closure window t_B = {t_b:.1f} h")
    top = max(h_w, d_i) * 1.25
    after = " after the breach" if t0 != 0 else ""
    marks = [(t0 + v, f"{n} = {v:.1f} h{after}", c) for v, n, c in ((t_q, "t_Q", "tab:blue"), (t_i, "t_I", "tab:green"))
             if np.isfinite(v)]
    close = len(marks) == 2 and abs(marks[0][0] - marks[1][0]) < 0.12 * (t_max - t_min)
    for k, (x, text, color) in enumerate(sorted(marks)):
        ax.axvline(x, color=color, lw=1.0, ls="-.")
        if t_min <= x <= t_max:
            ax.annotate(text, (x, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 3 + 12 * k * close),
                        textcoords="offset points", va="bottom", ha="center", fontsize=9, color=color)
    ax.annotate(f"h_W = {h_w:.2g} m (crest)", (0, h_w), xytext=(6, 4), textcoords="offset points", fontsize=9,
                color="tab:blue")
    if np.isfinite(t_b):
        depth = _scalar(ds, "depth_at_window_end")
        ax.plot([t0 + t_b], [depth], "o", color="black", ms=5)
        ax.annotate(f"{depth * 100:.0f} cm at end of window", (t0 + t_b, depth), xytext=(8, -14),
                    textcoords="offset points", fontsize=9, bbox=dict(fc="white", ec="none", alpha=0.8, pad=1))
    if "wind_speed" in ds:
        ax2 = ax.twinx()
        ax2.plot(ds["wind_time"].values / HOUR, ds["wind_speed"].values, color="tab:gray", lw=1.2,
                 label="wind speed (right axis)")
        limits = np.atleast_1d(ds["wind_limit"].values)
        ax2.axhline(limits[0], color="tab:gray", ls=":", lw=1.2, label=f"crane wind limit {limits[0]:.0f} m/s")
        ax2.set_ylabel("wind speed (m/s)", color="0.35")
        ax2.set_ylim(0, max(float(ds["wind_speed"].max()), limits[0]) * 1.3)
        if "work_start_delay" in ds and np.isfinite(_scalar(ds, "work_start_delay")):
            ax.axvline(t0 + _scalar(ds, "work_start_delay") / HOUR, color="0.3", lw=1.0, ls="--",
                       label=f"cranes may work (wind ≤ {limits[0]:.0f} m/s)")
    ax.set_xlim(t_min, t_max)
    ax.set_ylim(0, top)
    ax.set_xlabel("elapsed time from the flood crest (h)")
    ax.set_ylabel("water height above ground (m)")
    gov = GOVERNING_NAMES[int(ds["governing"])]
    ax.set_title((title + f": {gov} governs") if title else f"Closure window: {gov} governs", fontsize=11, pad=28)
    ax.grid(True, alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    for other in fig_axes_twins(ax):
        h2, l2 = other.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.08 if "wind_speed" in ds else 1.01, 1.0),
              fontsize=8, framealpha=0.9)


def fig_axes_twins(ax):
    """Twin axes sharing *ax*'s x axis (for a combined legend)."""
    return [other for other in ax.figure.axes if other is not ax and other.bbox.bounds == ax.bbox.bounds]


def window_chart(datasets, path, titles=None) -> Path:
    """Write a Fig 2.6-style chart of one or more scalar closure-window Datasets (one panel each)."""
    plt = _pyplot()
    datasets = [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)
    titles = titles or [None] * len(datasets)
    fig, axes = plt.subplots(len(datasets), 1, figsize=(12, 4.8 * len(datasets)), squeeze=False)
    for ax, ds, title in zip(axes[:, 0], datasets, titles):
        draw_window(ax, ds, title)
    fig.tight_layout()
    return _save(fig, path)


#: Fig 2.15: 3.0 m and 4.6 m levees, crown 3.0 m, slopes 1V:3H, water at the crest.
FIGURE_2_15_LEVEES = (LeveeGeometry(3.0, 3.0, 3.0, 3.0), LeveeGeometry(4.6, 3.0, 3.0, 3.0))


def growth_y_max(peaks) -> tuple[float, list[int]]:
    """Top of the growth chart's y axis, scaled to the curves: 10 % above the highest curve, unless one
    runs away (more than 2.5 times the median curve's peak, like eq 2.2's exponential): those are left
    to leave the chart (their indices are returned) and the axis fits the others."""
    peaks = np.asarray([p for p in peaks], float)
    finite = peaks[np.isfinite(peaks) & (peaks > 0)]
    if finite.size == 0:
        return 1.0, []
    limit = 2.5 * float(np.median(finite))
    keep = finite[finite <= limit]
    top = float(keep.max() if keep.size else finite.max())
    return 1.1 * top, [i for i, p in enumerate(peaks) if np.isfinite(p) and p > limit]


def growth_chart(path, *, levees=None, surge_height=None, equations="all", hours: float = 8.0,
                 max_length=None, y_max: float | None = None) -> Path:
    """Fig 2.15-style breach growth curves. With two levees (default: the report's 3.0 m and 4.6 m),
    each equation is a band between them; with one, a line. ``max_length`` caps the curves. The y axis
    is scaled to the curves (:func:`growth_y_max`) unless *y_max* (m) is given."""
    import warnings

    from ..errors import BreachflowWarning
    from .growth import breach_length, growth_equations

    plt = _pyplot()
    levees = list(levees) if levees is not None else list(FIGURE_2_15_LEVEES)
    time = xr.DataArray(np.linspace(0.0, hours, 321), dims="development_time", attrs={"units": "h"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)
        curves = [breach_length(equations, time, levee=lev, surge_height=surge_height, max_length=max_length)
                  for lev in levees]
    fig, ax = plt.subplots(figsize=(12, 6.5))
    hours_axis = time.values
    names = list(np.atleast_1d(curves[0]["equation"].values)) if "equation" in curves[0].dims else [equations]
    colors = plt.get_cmap("tab10")
    peaks = [max(float(np.nanmax((c.sel(equation=n) if "equation" in c.dims else c).values)) for c in curves)
             for n in names]
    auto_top, runaway = growth_y_max(peaks)
    y_max = auto_top if y_max is None else float(y_max)
    for i, name in enumerate(names):
        lines = [(c.sel(equation=name) if "equation" in c.dims else c).values for c in curves]
        cls = growth_equations.get(name)
        style = dict(color=colors(i % 10), lw=2.0, ls="--" if cls.equation == "rate" else "-")
        label = f"({cls.equation}) {cls.title}" if cls.equation != "rate" else f"{cls.title} (observed rate)"
        lo, hi = np.minimum(*lines) if len(lines) > 1 else lines[0], np.maximum(*lines) if len(lines) > 1 else lines[0]
        if len(lines) > 1 and max_length is not None:  # caps differ per levee: lines, not bands
            ax.plot(hours_axis, lines[-1], **style, label=label)
            ax.plot(hours_axis, lines[0], **{**style, "lw": 1.0})
        elif len(lines) > 1 and not np.allclose(lo, hi):
            ax.fill_between(hours_axis, lo, hi, color=style["color"], alpha=0.25, lw=0)
            ax.plot(hours_axis, hi, **style, label=label)
            ax.plot(hours_axis, lo, **{**style, "lw": 1.0})
        else:
            ax.plot(hours_axis, hi, **style, label=label)
    # breach sizes used in flood-routing studies (report §2.6): California Delta narrow / wide breaches
    for (y0, y1), text in (((30, 90), "narrow breach 30–90 m"), ((152, 228), "wide breach 152–228 m")):
        if y0 >= y_max:
            continue
        ax.axhspan(y0, y1, color="0.85", alpha=0.5, lw=0, zorder=0)
        top_visible = y1 < 0.9 * y_max
        ax.annotate(text + " (Calif. Delta studies)", (hours * 0.995, y1 if top_visible else y0),
                    ha="right", va="top" if top_visible else "bottom", fontsize=8, color="0.35")
    for i in runaway:  # say where the curves that leave the chart do so
        name = names[i]
        line = np.max([(c.sel(equation=name) if "equation" in c.dims else c).values for c in curves], axis=0)
        above = np.flatnonzero(line > y_max)
        if above.size:
            ax.annotate(f"({growth_equations.get(name).equation}) reaches {peaks[i]:.3g} m at {hours:g} h",
                        (hours_axis[above[0]], y_max), xytext=(3, -10), textcoords="offset points", fontsize=8,
                        color=colors(i % 10))
    ax.set_xlim(0, hours)
    ax.set_ylim(0, y_max)
    ax.set_xlabel("breach development time t_D (h)")
    ax.set_ylabel("breach length B (m)")
    desc = ", ".join(f"h_L = {lev.height:.1f} m" for lev in levees)
    ax.set_title(f"Breach growth by empirical equations (report Table 2.8; {desc}; "
                 f"crown {levees[0].crown_width:.1f} m, slopes 1V:{levees[0].flood_slope:g}H)", fontsize=10)
    if max_length is not None:
        caps = ", ".join(f"{c.attrs.get('max_length_m', float('nan')):.0f} m" for c in curves)
        ax.text(0.01, 0.99, f"capped at {caps} ({curves[0].attrs.get('capped_by', '')}); thin lines: "
                f"h_L = {levees[0].height:.1f} m", transform=ax.transAxes, va="top", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, framealpha=0.9)
    fig.tight_layout()
    return _save(fig, path)


def _save(fig, path) -> Path:
    plt = _pyplot()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=130, format=path.suffix.lstrip(".") or "png")
    plt.close(fig)
    return path
