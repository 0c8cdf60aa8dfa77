"""``breachflow export``: a snapshot NetCDF back into ADH/SMS, ESRI ASCII grid or HEC-RAS sdf text files."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def export(
        snapshot: Path = typer.Argument(..., help="Snapshot NetCDF (from `breachflow solve`, `ingest` or a run)."),
        format: str = typer.Option(..., "--format", "-f", help="adh | esri | sdf"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Output prefix (adh, esri: PREFIX.3dm, PREFIX_dep.dat, ...; sdf: PREFIX.sdf)."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        units: str = typer.Option("m", "--units", help="Length unit of the files: m or ft (velocities in unit/s)."),
        nodes: Optional[int] = typer.Option(None, "--nodes", help="adh from a grid: triangulate onto an unaligned mesh of about N nodes (default: nodes at the cell centres)."),
        seed: int = typer.Option(0, "--seed", help="adh --nodes: seed of the mesh's rotation and jitter."),
        sections: int = typer.Option(5, "--sections", help="sdf: number of cross sections cut across the mean flow."),
        points: int = typer.Option(41, "--points", help="sdf: points per cut line."),
        time_index: int = typer.Option(-1, "--time-index", help="esri: time step to write (default: the last)."),
    ) -> None:
        """Write a snapshot as ADH/SMS (.3dm, _dep.dat, _vel.dat, .bc), ESRI ASCII grids or a HEC-RAS RASExport.sdf."""
        from ..errors import InputError
        from ..hydro.io.meshing import to_unaligned_mesh
        from ..hydro.io.sdf_writer import write_sdf
        from ..hydro.io.writers import write_adh, write_esri
        from ..hydro.snapshot import is_mesh, read_snapshot
        from ._common import console, pick_out

        output = pick_out(out, output)
        if output is None:
            raise typer.BadParameter("give the output prefix with --out/-o", param_hint="--out")

        fmt = format.lower()
        if fmt not in ("adh", "esri", "sdf"):
            raise InputError(f"--format {format!r}: choose adh, esri or sdf")
        ds = read_snapshot(snapshot)
        if fmt == "adh":
            if nodes is not None:
                if is_mesh(ds):
                    raise InputError("--nodes triangulates a grid snapshot; this snapshot is already a mesh")
                ds = to_unaligned_mesh(ds, nodes, seed)
            paths = write_adh(ds, output, units=units)
        elif fmt == "esri":
            paths = write_esri(ds, output, units=units, time_index=time_index)
        else:
            sdf = output if output.suffix.lower() == ".sdf" else output.with_name(output.name + ".sdf")
            paths = [write_sdf(ds, sdf, n_sections=sections, points=points, units=units)]
        con = console()
        for p in paths:
            con.print(f"wrote {p}")
