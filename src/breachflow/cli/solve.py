"""``breachflow solve``: run the embedded shallow-water solver on a breach scene to steady state.

Writes the hydrodynamic snapshot ``snapshot.nc`` (CF NetCDF, schema data_schemas/snapshot_grid.json) into its
output directory ``--out`` (as ``run``, ``ensemble`` and ``atlas`` do: an existing result there is replaced
only with ``--overwrite``) and, when asked, a plan-view speed map (PNG), both atomically, and prints the peak depth-averaged velocity near the breach next to the report's ADH value
and Ritter's dam-break estimate ``u = 2/3 sqrt(g h_L)`` (docs/theory.md, *Breach discharge*).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

from typing import Optional

import typer

from ..atomic import atomic_write as _atomic_write

SCENES = ("typical_breach", "demo_breach")  #: the presets of ``[site] preset`` (breachflow.cycle.config.SITE_PRESETS)
DEFAULT_OUT = Path("runs/solve")  #: ``--out`` when none is given
SNAPSHOT = "snapshot.nc"          #: the snapshot's name in the output directory
_OLD_SUFFIXES = (".nc", ".nc4")   #: an ``--out`` ending so is the snapshot file itself (the old usage)


def solve_target(out: Path | None, overwrite: bool) -> Path:
    """The snapshot file ``solve`` writes for ``--out`` *out*, decided before anything is written.

    *out* is the output directory (default :data:`DEFAULT_OUT`); the snapshot is ``OUT/snapshot.nc``, and
    a directory that holds one already is refused unless *overwrite*. A value ending in ``.nc`` names the
    snapshot file itself (the usage before the output directory): accepted, with a DeprecationWarning
    naming the new form, and replaced as before."""
    import warnings

    from ..errors import InputError

    out = DEFAULT_OUT if out is None else Path(out)
    if out.suffix.lower() in _OLD_SUFFIXES and not out.is_dir():
        with warnings.catch_warnings():  # shown on the console, not hidden by Python's default filter
            warnings.simplefilter("always", DeprecationWarning)
            warnings.warn(f"solve --out {out}: a snapshot file as --out is deprecated; give an output directory "
                          f"(--out {out.with_suffix('')} writes {out.with_suffix('') / SNAPSHOT})",
                          DeprecationWarning, stacklevel=2)
        return out
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory (solve writes {SNAPSHOT} into a directory)")
    target = out / SNAPSHOT
    if target.exists() and not overwrite:
        raise InputError(f"{out} holds a solve already ({target}); refusing to replace it. "
                         f"Use --overwrite to replace it, or another --out directory")
    return target



def plot_speed(ds, path: Path, title: str = "") -> None:
    """Plan view of the depth-averaged speed with obstacles in grey and the peak marked (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..field.derived import peak_speed

    s = np.hypot(ds.u.values, ds.v.values)
    s = np.where(ds.wet.values > 0, s, np.nan)
    x, y = ds.x.values, ds.y.values
    fig, ax = plt.subplots(figsize=(11, 5.8), dpi=110)
    m = ax.pcolormesh(x, y, s, shading="nearest", cmap="turbo")
    if "obstacle" in ds:
        obst = np.where(ds.obstacle.values > 0, 1.0, np.nan)
        ax.pcolormesh(x, y, obst, shading="nearest", cmap="Greys", vmin=0, vmax=1.5)
    pk = peak_speed(ds)
    ax.plot(pk["x"], pk["y"], "w*", ms=12, mec="k")
    ax.annotate(f"peak {pk['speed']:.2f} m/s", (pk["x"], pk["y"]), xytext=(10, 10), textcoords="offset points",
                color="k", bbox=dict(boxstyle="round", fc="w", alpha=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x along the levee (m)")
    ax.set_ylabel("y from the levee centreline (m), flood side < 0")
    ax.set_title(title or "depth-averaged speed")
    fig.colorbar(m, ax=ax, label="depth-averaged speed (m/s)", shrink=0.85)
    fig.tight_layout()
    _atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)


def register(app: typer.Typer) -> None:
    @app.command()
    def solve(
        scene: str = typer.Argument("typical_breach", help=f"breach scene preset: {', '.join(SCENES)}"),
        resolution: str = typer.Option("4 m", help="grid spacing (with units)"),
        order: int = typer.Option(2, help="1 = first order, 2 = MUSCL + SSP-RK2"),
        courant: float = typer.Option(0.45, help="CFL number (0 < C <= 1)"),
        tolerance: str = typer.Option("1e-4 1/s", help="steady state: relative rate of change of depth and discharge"),
        t_max: str = typer.Option("1 h", help="simulated-time limit"),
        monitor_radius: str = typer.Option("auto", help="steady state judged within this distance of the breach centre ('auto' = twice the breach length, '' = whole domain)"),
        manning: str = typer.Option("", help="override Manning's n (s m^-1/3)"),
        breach_length: str = typer.Option("", help="override the breach length B (e.g. '61 m')"),
        levee_as_bed: bool = typer.Option(False, help="intact levee as bed instead of a no-flow boundary"),
        threads: int = typer.Option(1, help="numba threads"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help=f"output directory: writes {SNAPSHOT} there "
                                           f"[default: {DEFAULT_OUT}]"),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        overwrite: bool = typer.Option(False, "--overwrite", help="Replace the snapshot already in --out."),
        png: str = typer.Option("", help="plan-view speed map (PNG) to write [default: none]"),
        crs: str = typer.Option("", help="CRS of the scene's coordinates (EPSG code, WKT or PROJ string, as [site] crs) "
                                "[default: the local transverse Mercator closure runs use]"),
    ) -> None:
        """Solve the shallow-water flow through a levee breach to steady state."""
        import dataclasses

        from rich.table import Table

        from ..errors import InputError
        from ..field.derived import peak_speed
        from ..swe import SWEOptions, SWESimulation
        from ..swe.domain import breach_domain, breach_vicinity
        from ..units import to_si
        from ._common import QUIET, console, level, pick_out

        if scene not in SCENES:
            raise InputError(f"scene {scene!r} unknown; available: {', '.join(SCENES)}")
        output = solve_target(pick_out(out, output), overwrite)
        from ..cycle.config import SITE_PRESETS

        sc = SITE_PRESETS[scene]()
        if manning:
            sc = dataclasses.replace(sc, manning_n=to_si(manning, name="--manning", kind="manning", default_unit="s/m**(1/3)", positive=True))
        if breach_length:
            sc = dataclasses.replace(sc, breach=dataclasses.replace(sc.breach, length=to_si(breach_length, name="--breach-length", kind="length", positive=True)))
        dx = to_si(resolution, name="--resolution", kind="length", positive=True)
        tol = to_si(tolerance, name="--tolerance", kind="1/s", default_unit="1/s", positive=True)
        tmax = to_si(t_max, name="--t-max", kind="time", positive=True)
        dom = breach_domain(sc, dx, levee_no_flow=not levee_as_bed)
        from ..field.crs import local_crs_wkt, resolve_crs

        # the CRS a closure run of the scene writes (the documented local one unless --crs)
        dom.crs_wkt = resolve_crs(crs, where="--crs", data_unit="m") if crs else local_crs_wkt()
        con = console()
        con.print(f"[bold]{scene}[/]: {dom.shape[1]} × {dom.shape[0]} cells of {dom.dx:.2f} × {dom.dy:.2f} m, order {order}")
        sim = SWESimulation(dom, SWEOptions(order=order, courant=courant, threads=threads))
        wall0 = time.perf_counter()
        region = None
        if monitor_radius == "auto":
            region = breach_vicinity(dom, sc)
        elif monitor_radius:
            region = breach_vicinity(dom, sc, to_si(monitor_radius, name="--monitor-radius", kind="length", positive=True))
        from ..progress import Progress

        with Progress("solving", total=tmax, unit="s simulated", console=con, quiet=level() <= QUIET) as bar:
            def progress(s_, h_):
                bar.update(s_.t, note=f"rates {h_.depth_rate[-1]:.1e} {h_.discharge_rate[-1]:.1e} 1/s (steady < {tol:.0e})")

            hist = sim.run_to_steady(tol, tmax, region=region, progress=progress)
        wall = time.perf_counter() - wall0
        ds = sim.snapshot()
        from ..atomic import atomic_write_netcdf

        output.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_netcdf(ds, output)
        near = peak_speed(ds, x_range=(-sc.breach.length, sc.breach.length), y_range=(-50.0, 50.0))
        pk = peak_speed(ds)
        g = sim.options.gravity
        ritter = 2.0 / 3.0 * math.sqrt(g * sc.levee.height)
        t = Table(title="steady-state breach flow")
        t.add_column("quantity")
        t.add_column("value", justify="right")
        t.add_row("simulated time", f"{sim.t:.0f} s ({sim.steps} steps)")
        t.add_row("steady state", f"{'yes' if hist.converged else 'no'} (last rates {hist.depth_rate[-1]:.2e}, {hist.discharge_rate[-1]:.2e} 1/s)")
        t.add_row("wall time", f"{wall:.1f} s")
        t.add_row("peak speed (whole domain)", f"{pk['speed']:.2f} m/s at x = {pk['x']:.0f} m, y = {pk['y']:.0f} m (h {pk['depth']:.2f} m)")
        t.add_row("peak speed within 50 m of the levee centreline", f"{near['speed']:.2f} m/s at x = {near['x']:.0f} m, y = {near['y']:.0f} m")
        if "adh_peak_velocity_m_s" in sc.notes:  # the report's typical breach only
            t.add_row("report (ADH), near the former levee centreline", f"{sc.notes['adh_peak_velocity_m_s']:.3g} m/s")
        t.add_row("Ritter 2/3 sqrt(g h_L)", f"{ritter:.2f} m/s")
        con.print(t)
        if png:
            plot_speed(ds, Path(png), title=f"{scene}: depth-averaged speed, {dom.dx:.1f} m cells, t = {sim.t:.0f} s")
            con.print(f"wrote {output} and {png}")
        else:
            con.print(f"wrote {output}")
