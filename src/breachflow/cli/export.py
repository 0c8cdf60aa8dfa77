"""``breachflow export``: a snapshot NetCDF back into ADH/SMS, ESRI ASCII grid, HEC-RAS sdf text files or a
HEC-RAS 6 2-D plan HDF."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def export(
        snapshot: Path = typer.Argument(..., help="Snapshot NetCDF (from `breachflow solve` or `ingest`), or a run's "
                                        "cycle file or `combine` archive."),
        cycle: Optional[int] = typer.Option(None, "--cycle", help="cycle of a run's file to export [default: the last one in the file]"),
        format: str = typer.Option(..., "--format", "-f", help="adh | esri | sdf | hecras_hdf"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Output prefix (adh, esri: PREFIX.3dm, PREFIX_dep.dat, ...; sdf: PREFIX.sdf; hecras_hdf: PREFIX.p01.hdf)."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        units: str = typer.Option("m", "--units", help="Length unit of the files: m or ft (velocities in unit/s)."),
        nodes: Optional[int] = typer.Option(None, "--nodes", help="adh, hecras_hdf from a grid: triangulate onto an unaligned mesh of about N nodes (default: nodes at the cell centres)."),
        seed: int = typer.Option(0, "--seed", help="--nodes: seed of the mesh's rotation and jitter."),
        sections: int = typer.Option(5, "--sections", help="sdf: number of cross sections cut across the mean flow."),
        points: int = typer.Option(41, "--points", help="sdf: points per cut line."),
        time_index: int = typer.Option(-1, "--time-index", help="esri: time step to write (default: the last)."),
    ) -> None:
        """Write a snapshot as ADH/SMS (.3dm, _dep.dat, _vel.dat, .bc), ESRI ASCII grids, a HEC-RAS RASExport.sdf
        or a HEC-RAS 6 2-D plan HDF (triangles as cells, face velocities)."""
        from ..errors import InputError
        from ..field.snapshot import is_mesh
        from ..io.meshing import to_unaligned_mesh
        from ..io.runfiles import read_grid_file
        from ..io.sdf_writer import write_sdf
        from ..io.writers import write_adh, write_esri
        from ._common import console, pick_out

        output = pick_out(out, output)
        if output is None:
            raise typer.BadParameter("give the output prefix with --out/-o", param_hint="--out")

        fmt = format.lower()
        if fmt not in ("adh", "esri", "sdf", "hecras_hdf"):
            raise InputError(f"--format {format!r}: choose adh, esri, sdf or hecras_hdf")
        ds = read_grid_file(snapshot, cycle)
        if nodes is not None and fmt not in ("adh", "hecras_hdf"):
            raise InputError(f"--nodes triangulates for adh or hecras_hdf, not {fmt}")
        if fmt in ("adh", "hecras_hdf"):
            if nodes is not None:
                if is_mesh(ds):
                    raise InputError("--nodes triangulates a grid snapshot; this snapshot is already a mesh")
                ds = to_unaligned_mesh(ds, nodes, seed)
            if fmt == "adh":
                paths = write_adh(ds, output, units=units)
            else:
                from ..io.hecras_hdf_writer import write_hecras_hdf

                hdf = output if output.suffix.lower() in (".hdf", ".h5") else output.with_name(output.name + ".p01.hdf")
                paths = [write_hecras_hdf(ds, hdf, units=units)]
        elif fmt == "esri":
            paths = write_esri(ds, output, units=units, time_index=time_index)
        else:
            sdf = output if output.suffix.lower() == ".sdf" else output.with_name(output.name + ".sdf")
            paths = [write_sdf(ds, sdf, n_sections=sections, points=points, units=units)]
        con = console()
        for p in paths:
            con.print(f"wrote {p}")
