#!/usr/bin/env python3
"""Closure feasibility sweep: breach length × polder area × mass size, one dask ensemble (issue 8).

    python pipelines/closure_feasibility.py OUTPUT_DIR [--full] [--workers N] [--scheduler tcp://HOST:8786]
    python pipelines/closure_feasibility.py OUTPUT_DIR --lengths 8 16 --areas 20 200 --sizes 2.5 --replicates 8

For which breach lengths, polder areas and mass sizes can the breach be closed inside its closure window?
Every member runs the ``closure`` member runner: the closure simulation of its scenario (docs/theory.md, *The closure cycle*: masses of
that diameter dropped cycle after cycle into the embedded shallow-water flow until the end criteria hold)
and its closure window (docs/theory.md, *Closure window*), so ``feasible = closure achieved and closure duration <= closure window``, the duration being the
delivery's (tonnes placed / the crane barge's 400 t/h). The flood is held frozen in the simulation
(``[closure] flood = "frozen"``): the polder area enters only the window; breach length enters both.

The base scenario is the embedded demo breach (3 m levee, water at the crest) on a coarse grid (2 m,
first order), 6 masses per cycle placed by a crane barge (400 t/h; a crane for units of up to 40 t, the
largest masses of ``--full`` being 37 t), at most 8 cycles, closed when the masses block half the
breach cross-section or no speed exceeds 1 m/s: a member takes a few CPU seconds once numba's cache is
warm. The default grid is 3 × 3 × 3 parameter combinations; ``--full`` runs 6 × 5 × 5. Each combination
runs ``--replicates`` placement seeds (default 4; the same seeds in every combination, common random
numbers), so the map shows the probability of closure inside the window with its 95 % Wilson interval,
not one random placement (``--replicates 1``: one member per cell, the feasibility category).

Writes ``OUTPUT_DIR/ensemble.nc`` (CF NetCDF, dims breach_length × polder_area × mass_size),
``OUTPUT_DIR/members/*/`` (one run directory per member: scenario, closure run, result.json) and
``OUTPUT_DIR/closure_feasibility.png`` (one map per mass size: P(closure inside the window)). Rerunning resumes: completed
members are skipped.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT_GRID = {"lengths": [8, 12, 16], "areas": [20, 60, 200], "sizes": [1.5, 2.0, 2.5]}
FULL_GRID = {"lengths": [6, 8, 10, 12, 14, 16], "areas": [10, 20, 50, 100, 200], "sizes": [1.0, 1.5, 2.0, 2.5, 3.0]}

#: the quick site every member of the feasibility pipelines runs on: the demo breach (3 m levee, 12 m
#: breach) on a coarse grid (2 m, first order), a hurricane flood (fall 0.3 m/h), a 100 ha polder
QUICK_SITE = """
[site]
preset = "demo_breach"
levee_length_each_side = "16 m"
flood_side_extent = "24 m"
protected_side_extent = "24 m"

[flood]
surge_height = "3 m"
rise_rate = "0.3 m/hr"
fall_rate = "0.3 m/hr"

[polder]
area = "100 ha"
inundation_depth = "1.5 m"

[breach]
length = "12 m"
depth = "3 m"
wall_slope = 0

[hydro]
resolution = "2 m"
order = 1
t_max_initial = "90 s"
t_max = "20 s"
monitor_radius = "12 m"

[dem]
max_time = "4 s"
"""

SPEC = """
[ensemble]
name = "closure feasibility"
description = "breach length x polder area x mass size: closure simulation and closure window (docs/theory.md: Closure window, The closure cycle)"
runner = "closure"
seed = 2026
replicates = {replicates}

[ensemble.vary]
"breach.length" = [{lengths}]
"polder.area" = [{areas}]
mass_size = {{ parameter = "placement.diameter", values = [{sizes}], long_name = "diameter of the dropped masses" }}

[scenario]
name = "closure feasibility member"

""" + QUICK_SITE + """
[placement]
batch = 6
release_height = "1 m"

[criteria]
mode = "any"
max_cycles = 8
max_speed = "1 m/s"
blocked_fraction = 0.5

# a quick screening with an impervious pile (the default, a porous pile, needs the overflow / seepage criteria),
# timed by a crane barge (cycle/delivery.py) at the fixed flood level: [flood] and [polder] give the window only
[closure]
remap = "raised_bed"
method = "barge_crane"
unit_mass = ["0 t", "40 t"]
flood = "frozen"
"""


def spec_text(lengths=DEFAULT_GRID["lengths"], areas=DEFAULT_GRID["areas"], sizes=DEFAULT_GRID["sizes"],
              replicates=4) -> str:
    """The ensemble spec over breach lengths (m), polder areas (ha) and mass diameters (m), with
    *replicates* placement seeds per combination."""
    def quoted(values, unit):
        return ", ".join(f'"{v:g} {unit}"' for v in values)

    return SPEC.format(lengths=quoted(lengths, "m"), areas=quoted(areas, "ha"), sizes=quoted(sizes, "m"),
                       replicates=int(replicates))


#: Categories of the feasibility map: (label, colour).
CATEGORIES = (("feasible", "#1a9850"), ("closed after the window", "#fdae61"),
              ("not closed in max_cycles", "#d73027"), ("member failed", "#999999"))


def categories(ds) -> "np.ndarray":
    """0 feasible, 1 closed but later than the window, 2 not closed, 3 member failed (per member)."""
    ok = ds["member_status"].values == 0
    achieved = ds["closure_achieved"].values == 1
    feasible = ds["feasible"].values == 1
    return np.where(~ok, 3, np.where(feasible, 0, np.where(achieved, 1, 2)))


def _label(ax, lengths, areas_ha, size):
    """The axes of one map panel: breach length across, polder area up, the mass size in the title."""
    ax.set_xticks(range(len(lengths)), [f"{v:g}" for v in lengths])
    ax.set_yticks(range(len(areas_ha)), [f"{v:g}" for v in areas_ha])
    ax.set_xlabel("breach length B (m)")
    ax.set_ylabel("polder area A_P (ha)")
    ax.set_title(f"masses of {size:g} m")


def probability_figure(ds, path: Path) -> Path:
    """One panel per mass size over breach length × polder area: P(closure inside the window) over the
    replicates (colour), with its 95 % Wilson interval and the median closure duration / window (h)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from breachflow.atomic import atomic_path

    ds = ds.transpose("mass_size", "polder_area", "breach_length", "replicate", ...)  # per-cycle variables: cycle last
    sizes = ds["mass_size"].values
    lengths, areas_ha = ds["breach_length"].values, ds["polder_area"].values / 1e4
    p = ds["closure_probability"].values
    lo, hi = ds["closure_probability_lower"].values, ds["closure_probability_upper"].values
    dur = ds["closure_duration_median"].values / 3600.0
    window_h = ds["closure_window"].isel(replicate=0).values / 3600.0
    fig, axes = plt.subplots(1, len(sizes), figsize=(3.8 * len(sizes) + 1.5, 3.9), squeeze=False,
                             constrained_layout=True)
    im = None
    for k, (ax, size) in enumerate(zip(axes[0], sizes)):
        im = ax.imshow(p[k], origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
        _label(ax, lengths, areas_ha, size)
        for j in range(len(areas_ha)):
            for i in range(len(lengths)):
                text = ("no member ran" if not np.isfinite(p[k, j, i]) else
                        f"P {p[k, j, i]:.2f} [{lo[k, j, i]:.2f}, {hi[k, j, i]:.2f}]\n"
                        f"{dur[k, j, i]:.2f} / {window_h[k, j, i]:.2f} h")
                ax.text(i, j, text, ha="center", va="center", fontsize=6.5)
    fig.colorbar(im, ax=axes[0].tolist(), label="P(closure inside the window)")
    fig.suptitle(f"Closure feasibility over {ds.sizes['replicate']} placement seeds "
                 "(cell: P [95 % Wilson], median closure duration / window)")
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def figure(ds, path: Path) -> Path:
    """With a ``replicate`` dimension: :func:`probability_figure`. Otherwise one panel per mass size over breach length × polder area: the feasibility category of each
    member, with its closure duration / closure window (h) printed in the cell."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from breachflow.atomic import atomic_path

    if "replicate" in ds.dims:
        return probability_figure(ds, path)
    ds = ds.transpose("mass_size", "polder_area", "breach_length", ...)
    cat = categories(ds)
    sizes = ds["mass_size"].values
    lengths, areas_ha = ds["breach_length"].values, ds["polder_area"].values / 1e4
    duration_h = ds["closure_duration"].values / 3600.0
    window_h = ds["closure_window"].values / 3600.0
    cmap = ListedColormap([c for _, c in CATEGORIES])
    fig, axes = plt.subplots(1, len(sizes), figsize=(3.6 * len(sizes) + 1.0, 3.8), squeeze=False,
                             constrained_layout=True)
    for k, (ax, size) in enumerate(zip(axes[0], sizes)):
        ax.imshow(cat[k], origin="lower", cmap=cmap, vmin=-0.5, vmax=len(CATEGORIES) - 0.5, aspect="auto")
        _label(ax, lengths, areas_ha, size)
        for j in range(len(areas_ha)):
            for i in range(len(lengths)):
                text = "failed" if cat[k, j, i] == 3 else f"{duration_h[k, j, i]:.2f} / {window_h[k, j, i]:.2f} h"
                ax.text(i, j, text, ha="center", va="center", fontsize=7)
    fig.legend(handles=[Patch(color=c, label=lab) for lab, c in CATEGORIES], loc="outside lower center",
               ncol=len(CATEGORIES), fontsize=8)
    fig.suptitle("Closure feasibility (cell: closure duration / closure window)")
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output", type=Path, nargs="?", default=Path("closure_feasibility"))
    ap.add_argument("--full", action="store_true", help="the full grid (6 x 5 x 5 members) instead of 3 x 3 x 3")
    ap.add_argument("--lengths", type=float, nargs="+", help="breach lengths (m), overriding the grid's")
    ap.add_argument("--areas", type=float, nargs="+", help="polder areas (ha), overriding the grid's")
    ap.add_argument("--sizes", type=float, nargs="+", help="mass diameters (m), overriding the grid's")
    ap.add_argument("--replicates", type=int, default=4,
                    help="placement seeds per combination (default 4; 1: one member per cell)")
    ap.add_argument("--workers", type=int, default=None, help="local worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, help="address of an existing dask scheduler")
    args = ap.parse_args(argv)

    from rich.console import Console

    from breachflow.ensemble import parse_spec, run
    from breachflow.atomic import atomic_write_text

    grid = dict(FULL_GRID if args.full else DEFAULT_GRID)
    for key in grid:
        if getattr(args, key):
            grid[key] = getattr(args, key)
    text = spec_text(**grid, replicates=args.replicates)
    console = Console()
    args.output.mkdir(parents=True, exist_ok=True)
    spec_path = args.output / "closure_feasibility.toml"
    atomic_write_text(text, spec_path)
    t0 = time.perf_counter()
    ds = run(parse_spec(text, path=spec_path), out=args.output, workers=args.workers, scheduler=args.scheduler,
             console=console)
    wall = time.perf_counter() - t0
    png = figure(ds, args.output / "closure_feasibility.png")
    console.print(f"wrote {png}")
    counts = np.bincount(categories(ds).ravel(), minlength=len(CATEGORIES))
    if "closure_probability" in ds:
        pr = ds["closure_probability"].values
        console.print(f"P(closure inside the window) over {ds.sizes['replicate']} seeds: "
                      f"{np.nanmin(pr):.2f} … {np.nanmax(pr):.2f} across {pr.size} combinations", highlight=False)
    console.print(f"{ds['member_status'].size} members in {wall:.1f} s wall (member CPU time, sum "
                  f"{float(np.nansum(ds['member_cpu_time'].values)):.1f} s): "
                  + ", ".join(f"{n} {label}" for n, (label, _) in zip(counts, CATEGORIES)), highlight=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
