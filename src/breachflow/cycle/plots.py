"""Plots of a closure run: plan view of the speed with the masses, and closure progress."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: CF unit strings of the criteria as a reader writes them (dimensionless: no unit)
_DISPLAY_UNITS = {"1": "", "m s-1": " m/s", "m3 s-1": " m³/s", "m3": " m³", "m2": " m²", "m day-1": " m/day"}


def _unit(units: str) -> str:
    return _DISPLAY_UNITS.get(units, f" {units}" if units else "")


def closure_reason(rundir) -> str:
    """Why the run counts as closed (or not), from the manifest: the criteria met at the last cycle,
    e.g. "closed at cycle 6: max_speed 0.0766 m/s <= 0.5 m/s; breach discharge -0.00 m³/s"."""
    man = rundir.manifest()
    if not man["cycles"]:
        return "no cycle completed"
    last = man["cycles"][-1]
    summ = last["summary"]
    crit = summ.get("criteria", {})
    met = [f"{k} {v['value']:.3g}{_unit(v['units'])} (threshold {v['threshold']:.3g}{_unit(v['units'])})"
           for k, v in crit.items() if v.get("satisfied")]
    q = f"breach discharge {summ.get('breach_discharge', float('nan')):.2f} m³/s"
    seal = man.get("metadata", {}).get("seal") or {}
    if seal.get("sealed"):  # the seal stage after the rock: the sealed dam's leakage
        q += (f" through the rock; sealed with {seal.get('seal_thickness_m', float('nan')):.2f} m of finer fill: "
              f"{abs(seal.get('leakage_m3_s', float('nan'))):.2f} m³/s left")
    elif summ.get("seepage_discharge", 0.0):  # a porous pile: what passes is seepage, left to the sealing
        q += f" (seepage {abs(summ['seepage_discharge']):.2f} m³/s through the pile, to be sealed with finer fill)"
    if summ.get("closed"):
        return f"closed at cycle {last['cycle']}: {', '.join(met) or summ.get('governing', '')} met; {q}"
    return (f"not closed after {last['cycle']} cycles" + (f" ({', '.join(met)} met, not enough)" if met else "")
            + f"; {q}")


def plot_plan_view(rundir, out, cycle: int | None = None) -> Path:
    """Write :func:`plan_view_figure` to *out* (PNG)."""
    plt = _plt()
    fig = plan_view_figure(rundir, cycle)
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


#: margin around the breach and the placed masses in the plan view: half the breach length, at least
#: twice the largest mass diameter and 5 m
PLAN_MARGIN_MIN = 5.0


def plan_extent(ds) -> tuple[float, float, float, float]:
    """``(x0, x1, y0, y1)`` of the plan view of cycle file *ds*: the breach section (global attribute
    ``breach_section``, ``x_start x_end y`` on the grid) and every placed mass inside the domain, with a
    margin (:data:`PLAN_MARGIN_MIN`, half the breach length, twice the largest mass), within the
    grid. A file without ``breach_section`` (written before it existed) is framed around the breach
    centre (``site_breach_centre``, else the origin) at +-25 m or around its masses."""
    x, y = np.asarray(ds.x.values, float), np.asarray(ds.y.values, float)
    hx = 0.5 * abs(x[1] - x[0]) if x.size > 1 else 0.0
    hy = 0.5 * abs(y[1] - y[0]) if y.size > 1 else 0.0
    gx0, gx1, gy0, gy1 = x.min() - hx, x.max() + hx, y.min() - hy, y.max() + hy
    if "breach_section" in ds.attrs:
        bx0, bx1, by = (float(v) for v in str(ds.attrs["breach_section"]).split())
    else:
        xc, yc = (float(v) for v in ds.attrs["site_breach_centre"].split()) if "site_breach_centre" in ds.attrs else (0.0, 0.0)
        bx0, bx1, by = xc - 25.0, xc + 25.0, yc
    xs, ys = [bx0, bx1], [by, by]
    dmax = 0.0
    if "particle_x" in ds:
        px, py = np.ravel(ds.particle_x.values), np.ravel(ds.particle_y.values)
        d = np.ravel(ds.particle_diameter.values)
        placed = np.isfinite(px) & np.isfinite(py) & (px >= gx0) & (px <= gx1) & (py >= gy0) & (py <= gy1)
        if "particle_active" in ds:
            placed &= np.ravel(ds.particle_active.values) > 0
        if placed.any():
            r = 0.5 * d[placed]
            xs += [float((px[placed] - r).min()), float((px[placed] + r).max())]
            ys += [float((py[placed] - r).min()), float((py[placed] + r).max())]
            dmax = float(d[placed].max())
    margin = max(PLAN_MARGIN_MIN, 0.5 * abs(bx1 - bx0), 2.0 * dmax)
    return (max(gx0, min(xs) - margin), min(gx1, max(xs) + margin),
            max(gy0, min(ys) - margin), min(gy1, max(ys) + margin))


def crs_name(ds) -> str | None:
    """Name of the CRS of cycle file *ds* (its grid mapping's ``crs_wkt``), or None."""
    wkt = ds["crs"].attrs.get("crs_wkt") if "crs" in ds else None
    if not wkt:
        return None
    try:
        from pyproj import CRS

        return CRS.from_wkt(wkt).name
    except Exception:  # an unreadable CRS is reported by the CF check, not by a plot
        return None


def map_axis_formatter():
    """Tick labels of map coordinates as GIS users read them: whole metres with thousands separators,
    no offset or scientific notation (matplotlib's default writes 676 100 m as "+6.761e5")."""
    from matplotlib.ticker import FuncFormatter

    return FuncFormatter(lambda v, _pos: f"{v:,.0f}" if abs(v) >= 1000 else f"{v:g}")


def _wrap(text: str, fig, fontsize: float) -> str:
    """*text* wrapped to the width of *fig* at *fontsize* (an average glyph is about 0.55 em wide)."""
    import textwrap

    width = max(20, int(fig.get_figwidth() * 72.0 / (0.55 * fontsize)) - 4)
    return "\n".join(textwrap.wrap(text, width)) if len(text) > width else text


def plan_view_figure(rundir, cycle: int | None = None):
    """Speed (m/s) in plan, no-flow cells hatched, bed contours, resting masses white and moving
    masses red; first and last cycle (or *cycle*), with a legend and, for the whole run, the reason it
    counts as closed (:func:`closure_reason`) as the title. Each panel frames the breach and every placed
    mass (:func:`plan_extent`); a site's map coordinates are written in full (no axis offset) with its
    CRS name."""
    plt = _plt()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cycles = rundir.completed_cycles()
    show = [cycles[0], cycles[-1]] if cycle is None and len(cycles) > 1 else [cycle or cycles[-1]]
    fig, axes = plt.subplots(1, len(show), figsize=(6.2 * len(show), 6.2), squeeze=False, constrained_layout=True)
    vmax = None
    files = {g: rundir.open_cycle(g) for g in show}
    boxes = np.array([plan_extent(ds) for ds in files.values()])  # one frame for every panel: the union
    frame = (boxes[:, 0].min(), boxes[:, 1].max(), boxes[:, 2].min(), boxes[:, 3].max())
    for ax, g in zip(axes[0], show):
        ds = files[g]
        speed = np.hypot(ds.u.values, ds.v.values)
        vmax = vmax or max(float(speed.max()), 0.1)
        x, y = ds.x.values, ds.y.values
        m = ax.pcolormesh(x, y, np.where(ds.wet.values > 0, speed, np.nan), cmap="viridis", vmin=0, vmax=vmax,
                          shading="nearest")
        ax.contour(x, y, ds.bed_elevation.values, levels=8, colors="0.6", linewidths=0.5)
        if "obstacle" in ds:
            ax.contourf(x, y, ds.obstacle.values, levels=[0.5, 1.5], colors="none", hatches=["////"])
        act = ds.particle_active.values > 0
        for px, py, d, rest in zip(ds.particle_x.values[act], ds.particle_y.values[act],
                                   ds.particle_diameter.values[act], ds.particle_resting.values[act]):
            ax.add_patch(plt.Circle((px, py), d / 2, fill=False, color="white" if rest > 0 else "red", lw=0.8))
        x0, x1, y0, y1 = frame
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        site = "site_breach_centre" in ds.attrs
        turned = "grid_rotation_deg" in ds.attrs
        if site:  # map coordinates (or the breach-aligned grid's, as large): in full, with the CRS
            from matplotlib.ticker import MaxNLocator

            for axis in (ax.xaxis, ax.yaxis):
                axis.set_major_formatter(map_axis_formatter())
                axis.set_major_locator(MaxNLocator(4))
            name = crs_name(ds)
            where = "breach-aligned grid" + (f" about {name}" if name else "") if turned else (name or "site CRS")
            ax.set_xlabel(f"x along the levee (m, {where})" if turned else f"easting (m, {where})")
            ax.set_ylabel(f"y across the levee (m, {where})" if turned else f"northing (m, {where})")
        else:
            ax.set_xlabel("x along the levee (m)")
            ax.set_ylabel("y across the levee (m), flood side < 0")
        ax.set_title(f"cycle {g}\n{int(act.sum())} masses, max speed in the domain {float(speed.max()):.2f} m/s",
                     fontsize=10)
    fig.colorbar(m, ax=axes[0].tolist(), label="depth-averaged speed (m/s)")
    handles = [Patch(facecolor="none", edgecolor="black", hatch="////", label="no-flow cells (levee, masses above water)"),
               Line2D([], [], color="0.6", lw=0.8, label="bed elevation contours"),
               Line2D([], [], ls="none", marker="o", mfc="none", mec="0.25", ms=9, label="resting mass (white ring)"),
               Line2D([], [], ls="none", marker="o", mfc="none", mec="red", ms=9, label="moving mass (red ring)"),
               Patch(facecolor="white", edgecolor="0.7", label="dry")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3 if len(show) == 1 else 5, fontsize=8, frameon=False)
    if cycle is None:
        fig.suptitle(_wrap(closure_reason(rundir), fig, 10), fontsize=10)
    # room between the figure title, the panel titles and the legend (constrained layout, in inches)
    fig.get_layout_engine().set(h_pad=0.12, w_pad=0.08)
    return fig


def gap_history(rundir) -> dict:
    """Per cycle, the open breach (cycle 0, the initial solve) first: ``masses``, ``tonnage`` (t),
    ``max_speed``, ``gap_max_speed``, ``gap_mean_speed`` (m/s) and ``breach_discharge`` (m³/s) as arrays
    (NaN where a run written before a quantity existed lacks it)."""
    man = rundir.manifest()
    init = man.get("metadata", {}).get("initial")
    rows = ([{"masses": 0, "tonnage": 0.0, **init}] if init else []) + [c["summary"] for c in man["cycles"]]
    keys = ("masses", "tonnage", "max_speed", "gap_max_speed", "gap_mean_speed", "breach_discharge")
    return {k: np.array([float(r.get(k, np.nan)) for r in rows]) for k in keys}


def plot_closure_progress(rundir, out) -> Path:
    """Max speed anywhere, the gap speeds (mean and max in the gap section) and the discharge through
    the breach against the number of masses placed."""
    plt = _plt()
    h = gap_history(rundir)
    masses = h["masses"]
    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    ax.plot(masses, h["max_speed"], "o-", color="C0", label="max speed (anywhere)")
    ax.plot(masses, h["gap_max_speed"], "^-", color="C1", label="gap speed, max")
    ax.plot(masses, h["gap_mean_speed"], "v:", color="C2", label="gap speed, mean")
    ax.set_xlabel("masses placed")
    ax.set_ylabel("depth-averaged speed (m/s)")
    ax2 = ax.twinx()
    # magnitude: the section discharge is negative when the flood is on the grid's north side
    ax2.plot(masses, np.abs(h["breach_discharge"]), "s--", color="C3", label="breach discharge")
    ax2.set_ylabel("discharge through the breach (m³/s)", color="C3")
    ax.set_ylim(bottom=0)
    ax2.set_ylim(bottom=0)
    lines = ax.get_lines() + ax2.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper right")
    ax.set_title("closure progress")
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
