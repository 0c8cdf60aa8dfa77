"""How packed the porous pile of a closure run is, cycle by cycle: the share of its volume by the porosity of
its layers, on the run's own flow grid.

    python benchmarks/dev/pile_porosity.py RUN [RUN ...] [--cycles 2,4,11] [--edges 0.392,0.5,0.7]

*RUN* is a closure run directory (only read). For each cycle file: the resting units and the grid of that
cycle, the porous pile the run built from them (``breachflow.cycle.remap.porous_pile``, the column in
layers), and the share of the pile's volume (each layer's thickness times the cell's area) whose porosity
lies between the ``--edges`` (0.392 is where the ``ergun_dilute`` law leaves Ergun's, docs/theory.md,
*Porous flow through the pile*), with the median porosity of the layers.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def volume_shares(pile, cell_area, edges):
    """Share of the pile's volume per porosity band ``[0, e0), [e0, e1), ..., [e_last, 1]`` and the layers'
    median porosity."""
    where = pile.height > 0
    porosity = pile.layer_porosity[where]
    volume = np.repeat(pile.height[where][:, None] / porosity.shape[1], porosity.shape[1], axis=1) * cell_area
    bounds = [0.0, *edges, 1.0 + 1e-9]
    shares = [float(volume[(porosity >= lo) & (porosity < hi)].sum() / volume.sum())
              for lo, hi in zip(bounds[:-1], bounds[1:])]
    return shares, float(np.median(porosity))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--cycles", help="cycles to read, e.g. 2,4,11 (default all)")
    ap.add_argument("--edges", default="0.392,0.5,0.7", help="porosity band edges")
    a = ap.parse_args(argv)
    import xarray as xr

    from breachflow.cycle.remap import porous_pile

    edges = [float(v) for v in a.edges.split(",")]
    bands = [f"{lo:g}-{hi:g}" for lo, hi in zip([0.0, *edges], [*edges, 1.0])]
    wanted = None if a.cycles is None else {int(c) for c in a.cycles.split(",")}
    for run in a.runs:
        print(run)
        for f in sorted(run.glob("cycle_*.nc")):
            cycle = int(f.stem.split("_")[1])
            if wanted is not None and cycle not in wanted:
                continue
            with xr.open_dataset(f) as ds:
                ds = ds.isel(cycle=0)
                x, y = ds.x.values.astype(float), ds.y.values.astype(float)
                bed = ds.bed_elevation.values.astype(float)
                pos = np.stack([ds[k].values for k in ("particle_x", "particle_y", "particle_z")], axis=1)
                radius = 0.5 * ds.particle_diameter.values
                use = ds.particle_active.values.astype(bool) & np.isfinite(pos).all(axis=1)
                resting = ds.particle_resting.values.astype(bool)[use]
            pile = porous_pile(x, y, bed, pos[use].astype(float), radius[use].astype(float), resting)
            shares, median = volume_shares(pile, abs((x[1] - x[0]) * (y[1] - y[0])), edges)
            print(f"  cycle {cycle:3d}: {int(resting.sum())} units at rest, {int((pile.height > 0).sum())} pile cells, "
                  f"median layer porosity {median:.2f}; volume share " +
                  ", ".join(f"{b}: {100 * s:.0f} %" for b, s in zip(bands, shares)))


if __name__ == "__main__":
    main()
