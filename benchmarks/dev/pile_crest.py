"""The pile's crest across the gap read from the masses themselves, cycle by cycle, independent of the flow grid.

    python benchmarks/dev/pile_crest.py RUN [RUN ...] [--flood 38.1] [--strip 2.07] [--gap -30.5 30.5]

*RUN* is a closure run directory (only read). For each cycle file: the gap (``--gap``, along x at the levee) cut
into strips of ``--strip`` m (default one nominal diameter of 10-15 t rock, 2.07 m), the crest of a strip the
highest top ``z + r`` of a unit whose centre lies in it; printed: the units in the breach, the strips whose crest
is below ``--flood`` (m), the lowest crest, the median elevation of the units' centres, and the units still moving
(speed above 0.05 m/s) when the cycle's DEM time ended. The run itself judged its crest on the flow grid's
columns (``breachflow.cycle.rock_end.gap_crests``); this reading is the same for every grid.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def strip_crests(x, z, r, gap, strip):
    """Crest (m) per strip across *gap* ``(x0, x1)``: the highest ``z + r`` of the units centred in it (-inf: none)."""
    edges = np.arange(gap[0], gap[1] + 1e-9, strip)
    top = z + r
    return np.array([top[(x >= a) & (x < a + strip)].max() if ((x >= a) & (x < a + strip)).any() else -np.inf
                     for a in edges[:-1]])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--flood", type=float, default=38.1, help="flood level (m)")
    ap.add_argument("--strip", type=float, default=2.07, help="strip width (m)")
    ap.add_argument("--gap", type=float, nargs=2, default=(-30.5, 30.5), help="gap ends along x (m)")
    a = ap.parse_args(argv)
    import xarray as xr

    for run in a.runs:
        print(run)
        for f in sorted(run.glob("cycle_*.nc")):
            with xr.open_dataset(f) as ds:
                ds = ds.isel(cycle=0)
                act = ds.particle_active.values.astype(bool) & np.isfinite(ds.particle_x.values)
                x, z, d = (ds[k].values[act] for k in ("particle_x", "particle_z", "particle_diameter"))
                speed = np.sqrt(sum(ds[k].values[act] ** 2 for k in
                                    ("particle_velocity_x", "particle_velocity_y", "particle_velocity_z")))
            crest = strip_crests(x, z, 0.5 * d, a.gap, a.strip)
            print(f"  {f.stem}: {x.size} units, {int((crest < a.flood).sum())} of {crest.size} strips below the "
                  f"flood (lowest {crest.min():.2f} m), median centre {np.median(z) if z.size else np.nan:.2f} m, "
                  f"{int((speed > 0.05).sum())} moving (max {speed.max() if speed.size else 0.0:.2f} m/s)")


if __name__ == "__main__":
    main()
