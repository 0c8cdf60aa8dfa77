"""``breachflow ensemble``: run a scenario ensemble on dask (local cluster or an existing scheduler)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def ensemble(
        spec: Optional[Path] = typer.Argument(None, help="Ensemble spec TOML: an ensemble table (runner, vary or members) and the base scenario."),
        scheduler: Optional[str] = typer.Option(None, help="Address of a running dask scheduler, e.g. tcp://10.0.0.5:8786 "
                                                "(dask-jobqueue / dask-kubernetes clusters). Default: a local cluster."),
        workers: Optional[int] = typer.Option(None, help="Worker processes of the local cluster (default: one per core); "
                                              "with --scheduler: use only this many of its workers."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Output directory (default: the spec's output, else SPEC.ensemble/)."),
        resume: bool = typer.Option(False, "--resume", help="Continue an ensemble in --out: skip the members an "
                                    "earlier run completed (as `run --resume`)."),
        overwrite: bool = typer.Option(False, "--overwrite", help="Run every member again in an --out that holds "
                                       "an ensemble."),
        retry_failed: bool = typer.Option(True, help="On resume, rerun members that failed before."),
        progress: bool = typer.Option(True, help="Show a progress bar over members."),
        list_runners: bool = typer.Option(False, "--list-runners", help="List the member runners and exit."),
    ) -> None:
        """Run every member of an ensemble on dask (full factorial over ensemble.vary, or the listed
        ensemble.members) and write one NetCDF Dataset with a dimension per varied parameter; member outputs
        stay in their own run directories, failed members are recorded, reruns resume."""
        from ..ensemble import member_runners, run
        from ._common import console as _console

        console = _console()
        if list_runners:
            for name in member_runners.available():
                doc = (member_runners.get(name).__doc__ or "").strip().splitlines()
                console.print(f"[bold]{name}[/]: {doc[0] if doc else ''}", highlight=False)
            return
        if spec is None:
            raise typer.BadParameter("give an ensemble spec TOML file (or --list-runners)")
        check_ensemble_target(spec, out, resume, overwrite)
        ds = run(spec, out=out, scheduler=scheduler, workers=workers, resume=resume, retry_failed=retry_failed,
                 progress=progress, console=console)
        console.print(summary_table(ds))
        from ..errors import InputError

        failed = int(ds.attrs.get("ensemble_failed", 0))
        total = int(ds["member_status"].size)
        if failed and failed == total:  # nothing to show for it: a failure, not a result
            import numpy as np

            errs = [str(e) for e in np.asarray(ds["member_error"].values).ravel() if str(e)] if "member_error" in ds else []
            raise InputError(f"every member of the ensemble failed ({failed} of {total}); the first error: "
                             f"{errs[0] if errs else 'see member_error in ensemble.nc'}")
        if failed:
            console.print(f"[bold yellow]{failed} of {total} members failed, {total - failed} ran[/]: their results are "
                          "missing (NaN) in ensemble.nc; member_error / member_error_type say why", highlight=False)


def check_ensemble_target(spec, out, resume: bool, overwrite: bool) -> None:
    """The convention of ``breachflow run`` (docs/cli.md): an output directory holding an ensemble is
    continued only with ``--resume`` and run again only with ``--overwrite``; otherwise refused, naming both."""
    from ..errors import InputError
    from ..ensemble.execute import plan

    if resume and overwrite:
        raise InputError("--resume continues an ensemble and --overwrite runs it again: give one of them")
    _, out_dir, _, _ = plan(spec, out)
    held = (out_dir / "ensemble.nc").exists() or any((out_dir / "members").glob("*/result.json"))
    if resume and not held:
        raise InputError(f"{out_dir}: nothing to resume (no ensemble there); start it without --resume")
    if held and not (resume or overwrite):
        raise InputError(f"{out_dir} holds an ensemble already; refusing to run it again. Use --resume to continue "
                         f"it (members done are kept), --overwrite to run every member again, or another --out")


def summary_table(ds):
    """Rich table: each result variable's range over the successful members, with units; failures listed."""
    import numpy as np
    from rich.table import Table

    from ..ensemble.dataset import STATUS_VARIABLES
    from ..units import Q_

    ok = ds["member_status"].values == 0
    table = Table(title=f"{ds.attrs.get('title', 'ensemble')}: {int(ok.sum())} of {ok.size} members ok",
                  title_justify="left")
    for col in ("variable", "min", "max", "units"):
        table.add_column(col, justify="right" if col in ("min", "max") else "left")
    for name, var in ds.data_vars.items():
        if name in STATUS_VARIABLES or not np.issubdtype(var.dtype, np.number) or var.attrs.get("ensemble_per_cycle"):
            continue  # per-cycle figures (cycle_<name>) are for plots, not the summary
        reduced = var.attrs.get("ensemble_reduction") == "replicate"
        vals = (var.values.ravel() if reduced else var.values[ok]).astype(float)
        if "_FillValue" in var.encoding:
            vals = vals[vals != var.encoding["_FillValue"]]
        vals = vals[np.isfinite(vals)]
        units = var.attrs.get("units", "")
        shown = var.attrs.get("display_units", units)
        if "flag_meanings" in var.attrs:
            lo = hi = ""
            if vals.size:
                meanings = var.attrs["flag_meanings"].split()
                flags = list(np.asarray(var.attrs["flag_values"]).tolist())
                seen = sorted({int(v) for v in vals})
                lo = ", ".join(meanings[flags.index(v)] for v in seen if v in flags)
            table.add_row(name, lo, hi, "flag")
            continue
        if vals.size == 0:
            table.add_row(name, "—", "—", shown)
            continue
        lo, hi = vals.min(), vals.max()
        if shown != units:
            lo, hi = (Q_(v, units.replace("^", "**")).to(shown.replace("^", "**")).magnitude for v in (lo, hi))
        table.add_row(name, f"{lo:.4g}", f"{hi:.4g}", shown)
    failed = np.flatnonzero(ds["member_status"].values.ravel() == 1)
    from rich.console import Group

    if "closure_probability" in ds:
        table = Group(table, probability_table(ds))
    if not failed.size:
        return table

    errors = Table(title=f"{failed.size} failed member(s)", title_justify="left", title_style="red")
    dims = list(ds["member_status"].dims)
    for col in (*dims, "error", "run directory"):
        errors.add_column(col)
    grids = np.meshgrid(*[ds[d].values for d in dims], indexing="ij")
    for i in failed[:20]:
        errors.add_row(*[str(g.ravel()[i]) for g in grids],
                       f"{ds['member_error_type'].values.ravel()[i]}: {ds['member_error'].values.ravel()[i]}",
                       str(ds["member_run_dir"].values.ravel()[i]))
    if failed.size > 20:
        errors.add_row(f"... {failed.size - 20} more", *[""] * (len(dims) + 1))
    return Group(table, errors)


def probability_table(ds):
    """Rich table for an ensemble with replicates: per parameter combination, P(closure) with its 95 %
    Wilson interval and the median (10–90 %) tonnage and closure duration."""
    import numpy as np
    from rich.table import Table

    p = ds["closure_probability"]
    dims = list(p.dims)
    t = Table(title=f"over {ds.sizes['replicate']} replicates (placement seeds)", title_justify="left")
    labels = [f"{d} ({ds[d].attrs['units']})" if ds[d].attrs.get("units", "1") != "1" else d for d in dims]
    for col in (*labels, "P(closure)", "95 % Wilson", "tonnage t, median (10-90 %)", "duration h, median (10-90 %)"):
        t.add_column(col)
    grids = np.meshgrid(*[ds[d].values for d in dims], indexing="ij") if dims else []

    def rng(name, scale):
        if f"{name}_median" not in ds:
            return "-"
        m, lo, hi = (ds[f"{name}_{k}"].values.ravel() for k in ("median", "p10", "p90"))
        return lambda i: f"{m[i] / scale:.4g} ({lo[i] / scale:.4g}-{hi[i] / scale:.4g})"

    ton, dur = rng("tonnage", 1000.0), rng("closure_duration", 3600.0)
    pv, lo, hi = p.values.ravel(), ds["closure_probability_lower"].values.ravel(), ds["closure_probability_upper"].values.ravel()
    for i in range(pv.size):
        t.add_row(*[str(g.ravel()[i]) for g in grids], f"{pv[i]:.2f}", f"[{lo[i]:.2f}, {hi[i]:.2f}]",
                  ton(i) if callable(ton) else ton, dur(i) if callable(dur) else dur)
    return t
