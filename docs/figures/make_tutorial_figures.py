"""Write the figures of docs/tutorials.md from the tutorials' own outputs.

    python3 tasks.py shell python docs/figures/make_tutorial_figures.py \
        --default runs/default --site runs/site --snapshot muncie.nc --ensemble runs/quick

Each option is optional; the figures of the outputs given are (re)written into docs/figures/:
the run's own plots (``plan_view.png``, ``closure_progress.png``) copied, the ingested snapshot's depth on
its mesh, and P(closure) with its Wilson interval from an ensemble's ``ensemble.nc``.
"""
from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.tri as mtri  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

HERE = Path(__file__).resolve().parent


def copy_run_plots(run: Path, name: str) -> None:
    for plot in ("plan_view.png", "closure_progress.png"):
        shutil.copyfile(run / plot, HERE / f"{name}_{plot}")


def snapshot_depth(path: Path) -> None:
    ds = xr.open_dataset(path)
    tri = mtri.Triangulation(ds["mesh2d_node_x"].values, ds["mesh2d_node_y"].values,
                             ds["mesh2d_face_nodes"].values)
    depth = ds["depth"].isel(time=-1).values
    fig, ax = plt.subplots(figsize=(7, 5.5), constrained_layout=True)
    pc = ax.tripcolor(tri, depth, shading="gouraud", cmap="Blues", vmin=0)
    fig.colorbar(pc, ax=ax, label="depth (m)")
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{Path(ds.attrs['source_files']).name}: depth at {str(ds['time'].values[-1])[:16]}")
    fig.savefig(HERE / "tutorial_ingest_depth.png", dpi=110)
    plt.close(fig)


def closure_probability(ens: Path) -> None:
    ds = xr.open_dataset(ens / "ensemble.nc")
    p = ds["closure_probability"]
    dim = [d for d in p.dims][0]
    x = ds[dim].values
    lo = ds["closure_probability_lower"].values.ravel()
    hi = ds["closure_probability_upper"].values.ravel()
    pv = p.values.ravel()
    fig, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    ax.errorbar(x, pv, yerr=[pv - lo, hi - pv], fmt="o", capsize=6, label="P(closure) with 95 % Wilson interval")
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel(f"{ds[dim].attrs.get('long_name', dim)} ({ds[dim].attrs.get('units', '')})")
    ax.set_ylabel("P(closure inside the window)")
    n = int(ds.sizes.get("replicate", 1))
    ax.set_title(f"{ds.attrs.get('ensemble_name', ens.name)}: {n} placement seeds per cell", fontsize=10)
    ax.margins(x=0.25)
    ax.set_xticks(x)
    ax.legend(loc="lower right")
    fig.savefig(HERE / "tutorial_ensemble_probability.png", dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--default", type=Path, help="run directory of the default scenario")
    ap.add_argument("--site", type=Path, help="run directory of examples/site/site.toml")
    ap.add_argument("--snapshot", type=Path, help="a snapshot written by `breachflow ingest`")
    ap.add_argument("--ensemble", type=Path, help="output directory of `breachflow ensemble`")
    a = ap.parse_args(argv)
    if a.default:
        copy_run_plots(a.default, "tutorial_default")
    if a.site:
        copy_run_plots(a.site, "tutorial_site")
    if a.snapshot:
        snapshot_depth(a.snapshot)
    if a.ensemble:
        closure_probability(a.ensemble)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
