"""``breachflow atlas``: a pre-event breach atlas of a levee district on dask (local cluster or a scheduler)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def atlas(
        district: Path = typer.Argument(..., help="District TOML: levee line, terrain, flood, polder, breach growth, "
                                                  "closure methods."),
        out: Path = typer.Option(..., "--out", "-o", help="Output directory (atlas.nc, atlas.gpkg, atlas.png, "
                                                           "locations/)."),
        scheduler: Optional[str] = typer.Option(None, help="Address of a running dask scheduler (tcp://host:8786) or "
                                                "a scheduler file (*.json). Default: a local cluster."),
        workers: Optional[int] = typer.Option(None, help="Worker processes of the local cluster (default: one per "
                                              "core)."),
        resume: bool = typer.Option(False, "--resume", help="Continue an atlas in --out: keep the locations an "
                                    "earlier run computed with the same inputs (as `run --resume`)."),
        overwrite: bool = typer.Option(False, "--overwrite", help="Compute every location again in an --out that "
                                       "holds an atlas."),
        progress: bool = typer.Option(True, help="Show progress over locations."),
        detailed: Optional[bool] = typer.Option(None, "--detailed/--screening-only",
                                                help="Run the closure simulation at the worst locations (default: when "
                                                     "the district file has a [detailed] table)."),
    ) -> None:
        """Screen every candidate breach along a district's levee: breach growth, open-breach flow, closure
        window, stone size, tonnage and the closure methods that fit; write a NetCDF along `location`, a
        GeoPackage of levee reaches and a feasibility map."""
        from ..atlas import run_atlas
        from ._common import console as _console

        console = _console()
        check_atlas_target(out, resume, overwrite)
        if overwrite:
            import shutil

            shutil.rmtree(out / "locations", ignore_errors=True)
            shutil.rmtree(out / "detailed", ignore_errors=True)  # the closure simulations' members too
        ds = run_atlas(district, out, scheduler=scheduler, workers=workers, resume=resume, progress=progress,
                       console=console, detailed=detailed)
        console.print(summary(ds))


def check_atlas_target(out: Path, resume: bool, overwrite: bool) -> None:
    """The convention of ``breachflow run`` (docs/cli.md): an --out holding an atlas is continued only with
    ``--resume`` and computed again only with ``--overwrite``; otherwise refused, naming both."""
    from ..errors import InputError

    if resume and overwrite:
        raise InputError("--resume continues an atlas and --overwrite computes it again: give one of them")
    held = (out / "atlas.nc").exists() or any((out / "locations").glob("*.json"))
    if resume and not held:
        raise InputError(f"{out}: nothing to resume (no atlas there); start it without --resume")
    if held and not (resume or overwrite):
        raise InputError(f"{out} holds an atlas already; refusing to compute it again. Use --resume to continue it "
                         f"(locations done are kept), --overwrite to compute every location again, or another --out")


def summary(ds):
    """Rich table of the worst locations (the smallest margin first)."""
    import numpy as np
    from rich.table import Table

    from ..atlas.outputs import CLASSES

    names = list(CLASSES)
    counts = ", ".join(f"{int(np.sum(ds.feasibility.values == i))} {n}" for i, n in enumerate(names)
                       if np.any(ds.feasibility.values == i))
    t = Table(title=f"{ds.sizes['location']} locations: {counts}; worst first", title_justify="left")
    for col in ("km", "head m", "B m", "Q m3/s", "u m/s", "window h", "D m", "tonnage t", "method", "finish h",
                "margin h"):
        t.add_column(col, justify="left" if col == "method" else "right")
    margin = np.where(np.isfinite(ds.margin_h.values), ds.margin_h.values, np.inf)
    for i in np.argsort(margin, kind="stable")[:10]:
        f = lambda v, d=1: "-" if not np.isfinite(v) else f"{v:.{d}f}"  # noqa: E731
        m = ds.method.values[i]
        t.add_row(f(ds.breach_chainage.values[i] / 1000.0, 2), f(ds.head_m.values[i], 2), f(ds.breach_length_m.values[i]),
                  f(ds.open_discharge_m3s.values[i], 0), f(ds.gap_speed_ms.values[i], 2),
                  f(ds.closure_window_h.values[i]), f(ds.stone_size_m.values[i], 2), f(ds.tonnage_t.values[i], 0),
                  m.decode() if isinstance(m, bytes) else str(m), f(ds.finish_h.values[i]), f(margin[i]))
    return t
