#!/usr/bin/env python3
"""Closure feasibility sweep: breach length × polder area × mass size, one dask ensemble (issue 8).

    python pipelines/closure_feasibility.py OUTPUT_DIR [--workers N] [--scheduler tcp://HOST:8786]

For which breach lengths, polder areas and mass sizes can the breach be closed inside its closure window?
Every member computes the closure window of its scenario (SPEC §2) and — with the "closure" member
runner of the closure-cycle issue — simulates the closure by dropping masses of that size, so that
``feasible = closure done before the window ends``.

Writes ``OUTPUT_DIR/ensemble.nc`` (CF NetCDF, dims breach_length × polder_area × mass_size),
``OUTPUT_DIR/members/*/`` (one run directory per member) and ``OUTPUT_DIR/closure_feasibility.png`` (one
panel per mass size: the closure window, and when the closure part ran, which cells are feasible).
Rerunning resumes: completed members are skipped.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

# The member runner. "window" computes closure windows only; switching to the closure simulation is this
# one line once the closure-cycle issue registers its runner: RUNNER = "closure".
RUNNER = "window"

SPEC = """
[ensemble]
name = "closure feasibility"
description = "breach length x polder area x mass size for the report's hurricane model problem (SPEC 2, 7)"
runner = "{runner}"
seed = 2026

[ensemble.vary]
"breach.length" = ["20 m", "40 m", "60 m", "80 m"]
"polder.area" = ["400 ha", "800 ha", "1600 ha", "3200 ha"]
mass_size = {{ parameter = "placement.mass_size", values = ["1 m", "2 m", "3 m"], long_name = "diameter of the dropped masses" }}

# the base scenario: the report's hurricane model problem (Table 2.5), Q_D = h_W B v
[scenario]
name = "closure feasibility member"

[flood]
surge_height = "2.8 m"
rise_rate = "40 cm/hr"
fall_rate = "40 cm/hr"
breach_time = "0 h"

[polder]
area = "800 ha"
inundation_depth = "90 cm"

[levee]
height = "2.4 m"

[breach]
length = "30 m"
mean_velocity = "3 m/s"
"""


def spec_text(runner: str = RUNNER) -> str:
    return SPEC.format(runner=runner)


def figure(ds, path: Path) -> Path:
    """One panel per mass size over breach length × polder area: closure window in hours; with the closure
    results, infeasible cells hatched and the closure duration printed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from breachflow.ensemble.io import atomic_path

    sizes = ds["mass_size"].values
    fig, axes = plt.subplots(1, len(sizes), figsize=(4.2 * len(sizes), 4.0), squeeze=False, constrained_layout=True)
    window_h = ds["closure_window"] / 3600.0
    vmax = float(np.nanmax(window_h.values)) if np.isfinite(window_h.values).any() else 1.0
    has_closure = "feasible" in ds
    for ax, size in zip(axes[0], sizes):
        w = window_h.sel(mass_size=size).transpose("polder_area", "breach_length")
        lengths, areas_ha = ds["breach_length"].values, ds["polder_area"].values / 1e4
        im = ax.imshow(w.values, origin="lower", cmap="viridis", vmin=0, vmax=vmax, aspect="auto")
        ax.set_xticks(range(len(lengths)), [f"{v:g}" for v in lengths])
        ax.set_yticks(range(len(areas_ha)), [f"{v:g}" for v in areas_ha])
        ax.set_xlabel("breach length B (m)")
        ax.set_ylabel("polder area A_P (ha)")
        status = ds["member_status"].sel(mass_size=size).transpose("polder_area", "breach_length").values
        feas = (ds["feasible"].sel(mass_size=size).transpose("polder_area", "breach_length").values
                if has_closure else None)
        for j in range(w.shape[0]):
            for i in range(w.shape[1]):
                if status[j, i] != 0:
                    ax.text(i, j, "failed", ha="center", va="center", color="red", fontsize=8)
                    continue
                text = f"{w.values[j, i]:.1f} h"
                if feas is not None:
                    ok = feas[j, i] == 1
                    text += "\nfeasible" if ok else "\nnot feasible"
                    if not ok:
                        ax.add_patch(plt.Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch="///",
                                                   edgecolor="white", linewidth=0))
                ax.text(i, j, text, ha="center", va="center", color="white", fontsize=8)
        ax.set_title(f"masses of {size:g} m" + ("" if has_closure else " (window only)"))
    fig.colorbar(im, ax=axes[0].tolist(), label="closure window t_B (h)")
    fig.suptitle("Closure feasibility: closure window" + (" and closure before its end" if has_closure
                                                           else " — closure part needs the 'closure' runner"))
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output", type=Path, nargs="?", default=Path("closure_feasibility"))
    ap.add_argument("--workers", type=int, default=None, help="local worker processes (default: one per core)")
    ap.add_argument("--scheduler", default=None, help="address of an existing dask scheduler")
    ap.add_argument("--runner", default=RUNNER, help=f"member runner (default {RUNNER!r})")
    args = ap.parse_args(argv)

    from rich.console import Console

    from breachflow.ensemble import member_runners, parse_spec, run, runner_available
    from breachflow.ensemble.io import atomic_write_text

    console = Console()
    if args.runner == "window":
        console.print("[bold yellow]closure part not run:[/] the closure simulation needs the 'closure' member runner "
                      "(closure-cycle issue), not registered yet"
                      + ("" if not runner_available("closure") else " — it is available now: use --runner closure")
                      + ". This run computes the closure window of every member; mass size does not enter it, "
                      "and no feasibility flag is computed.")
    elif not runner_available(args.runner):
        console.print(f"[red]member runner {args.runner!r} is not registered[/] (available: "
                      f"{', '.join(member_runners.available())})")
        return 2
    args.output.mkdir(parents=True, exist_ok=True)
    spec_path = args.output / "closure_feasibility.toml"
    atomic_write_text(spec_path, spec_text(args.runner))
    ds = run(parse_spec(spec_text(args.runner), path=spec_path), out=args.output, workers=args.workers,
             scheduler=args.scheduler, console=console)
    png = figure(ds, args.output / "closure_feasibility.png")
    console.print(f"wrote {png}")
    if "feasible" in ds:
        feasible = ds["feasible"].where(ds["member_status"] == 0)
        console.print(f"feasible members: {int((feasible == 1).sum())} of {int((ds['member_status'] == 0).sum())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
