"""``breachflow ingest`` (model exports → snapshot NetCDF) and ``breachflow inspect`` (summary of one)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def _coordinate(value: float) -> str:
    """A map coordinate to the centimetre, without trailing zeros: projected northings have seven digits
    before the point (``4178230``), which a fixed number of significant digits would round away."""
    return f"{float(value):.2f}".rstrip("0").rstrip(".")


def _time_steps(time) -> str:
    """``N: first .. last`` of a time axis: dates to the second, model times with their unit, and steady
    profiles (dimensionless, e.g. HEC-RAS profile numbers) by their long name instead of a unit ``1``."""
    import numpy as np

    t = time.values
    if t.dtype.kind == "M":
        first, last = (np.datetime_as_string(v, unit="s") for v in (t[0], t[-1]))
        return f"{t.size}: {first} .. {last}"
    units = time.attrs.get("units", "")
    if units in ("1", ""):
        return f"{t.size}: {t[0]:g} .. {t[-1]:g}" + (f" ({time.attrs['long_name']})" if time.attrs.get("long_name") else "")
    return f"{t.size}: {t[0]:g} .. {t[-1]:g} {units}"


def summary_rows(ds) -> list[tuple[str, str]]:
    """(label, text) rows describing a snapshot: kind, size, extent, time steps and value ranges."""
    import numpy as np

    from ..field.snapshot import is_mesh, node_coordinates

    rows = []
    if is_mesh(ds):
        x, y = node_coordinates(ds)
        rows.append(("kind", "UGRID mesh (values at nodes)"))
        rows.append(("size", f"{ds.sizes['node']} nodes, {ds.sizes['face']} faces"))
    else:
        x, y = ds["x"].values, ds["y"].values
        rows.append(("kind", "structured grid (cell centres)"))
        rows.append(("size", f"{ds.sizes['x']} x {ds.sizes['y']} = {ds.sizes['x'] * ds.sizes['y']} cells"))
    rows.append(("extent", f"x {_coordinate(x.min())} .. {_coordinate(x.max())} m, "
                           f"y {_coordinate(y.min())} .. {_coordinate(y.max())} m"))
    if "time" in ds.dims:
        rows.append(("time steps", _time_steps(ds["time"])))
    else:
        rows.append(("time steps", "1 (no time axis)"))
    for name, label in (("bed_elevation", "bed elevation"), ("depth", "depth"), ("water_surface", "water surface")):
        a = ds[name].values
        rows.append((label, f"{np.nanmin(a):.4g} .. {np.nanmax(a):.4g} {ds[name].attrs.get('units', '')}"))
    speed = np.hypot(ds["u"].values, ds["v"].values)
    rows.append(("speed", f"{speed.min():.4g} .. {speed.max():.4g} m s-1"))
    rows.append(("wet", f"{100 * ds['wet'].values.mean():.1f} % of values"))
    rows.append(("CRS", "yes (grid_mapping 'crs')" if "crs" in ds.variables else "unknown"))
    for key in ("breachflow_reader", "source_length_unit", "source_length_unit_from", "source_files"):
        if ds.attrs.get(key):
            rows.append((key.replace("_", " "), str(ds.attrs[key]).replace(";", "; ")))
    return rows


def _print(title: str, ds) -> None:
    from rich.table import Table

    table = Table(title=title, show_header=False)
    table.add_column(style="bold")
    table.add_column()
    for k, v in summary_rows(ds):
        table.add_row(k, v)
    from ._common import console

    console().print(table)


def register(app: typer.Typer) -> None:
    @app.command()
    def ingest(
        files: List[Path] = typer.Argument(..., help="Model export files forming one snapshot (mesh + .dat + .bc; .asc grids; one .sdf; a HEC-RAS .hdf)."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Snapshot NetCDF file to write (atomically)."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        format: Optional[str] = typer.Option(None, "--format", "-f", help="Reader name (default: from the extensions)."),
        units: Optional[str] = typer.Option(None, "--units", help="Length unit of files that carry none: m or ft."),
        crs: Optional[str] = typer.Option(None, "--crs", help="CRS as EPSG:nnnn, WKT text or a .prj file (overrides the files); in the files' length unit; stored as WKT."),
        strict: bool = typer.Option(False, "--strict", help="Reject unknown cards instead of warning."),
        time_units: Optional[str] = typer.Option(None, "--time-units", help="Time unit of .dat steps (overrides TIMEUNITS)."),
        plausibility: str = typer.Option("raise", "--plausibility", help="raise | warn | off"),
        bed: Optional[str] = typer.Option(None, "--bed", help="Bed elevation with unit when no terrain grid is given (asc)."),
        velocity_direction: Optional[float] = typer.Option(None, "--velocity-direction", help="Degrees anticlockwise from +x for speed-only grids (asc)."),
        role: List[str] = typer.Option([], "--role", help="FILE=ROLE for grids (depth, water_surface, bed, u, v, speed); NAME=ROLE for .dat datasets (depth, water_surface, velocity, ignore; NAME = dataset NAME or file name)."),
        mesh_name: Optional[str] = typer.Option(None, "--mesh-name", help="HEC-RAS HDF: read only this 2-D flow area."),
    ) -> None:
        """Read hydrodynamic model exports, check them and write one SI snapshot NetCDF (CF, UGRID for meshes)."""
        from ..errors import InputError
        from ..io import open_snapshot
        from ..field.snapshot import write_snapshot

        options = {}
        if strict:
            options["strict"] = True
        if time_units:
            options["time_units"] = time_units
        if bed is not None:
            options["bed"] = bed
        if velocity_direction is not None:
            options["velocity_direction"] = velocity_direction
        if mesh_name:
            options["mesh_name"] = mesh_name
        if role:
            roles = {}
            for r in role:
                if "=" not in r:
                    raise InputError(f"--role {r!r}: expected FILE=ROLE")
                f, v = r.rsplit("=", 1)
                roles[f] = v
            options["roles"] = roles
        if crs and Path(crs).is_file():
            from ..io import read_prj

            crs = read_prj(crs)
        from ..errors import BreachflowError
        from ._common import cli_flags, pick_out

        output = pick_out(out, output)
        if output is None:
            raise typer.BadParameter("give the snapshot file to write with --out/-o", param_hint="--out")
        try:
            ds = open_snapshot(files, format=format, units=units, crs=crs, plausibility=plausibility, **options)
        except BreachflowError as exc:
            raise cli_flags(exc)
        write_snapshot(ds, output)
        _print(f"wrote {output}", ds)

    @app.command()
    def inspect(snapshot: Path = typer.Argument(..., help="Snapshot NetCDF written by `breachflow ingest` or `solve`, "
                                                "or a run's cycle file or `combine` archive."),
                cycle: Optional[int] = typer.Option(None, "--cycle", help="cycle of a run's file to inspect "
                                                    "[default: the last one in the file]")) -> None:
        """Validate a snapshot NetCDF and print its summary."""
        from ..io.runfiles import read_grid_file

        ds = read_grid_file(snapshot, cycle)
        _print(str(snapshot), ds)
