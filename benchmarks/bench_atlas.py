"""Breach-atlas screening at district scale: a levee of ``--length`` metres (default 20 km) at ``--spacing``
(default 200 m: 100 locations) through the screening tier on a local dask cluster.

    python3 tasks.py bench atlas [--length 20000] [--spacing "200 m"] [--workers 2] [--flow swe] [--reps 1]

Prints the wall time of the whole atlas (terrain made beforehand, not timed), the CPU time of the locations
(the workers' ``solve_cpu_s``), the scheduling efficiency ``sum(location CPU) / (workers x wall)`` and the
spread of the open-breach discharge as its error figure: the same locations at half the cell size
(``--check-resolution``, on a sample of ``--check`` locations) against the atlas resolution.
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TOML = """
[district]
name = "benchmark district"
terrain = "{terrain}"
levee = "{levee}"
flood_side = "left"
spacing = "{spacing}"
margin = "100 m"

[flood]
level = "5.0 m"
fall_rate = "1 cm/h"

[polder]
area = "12000 ha"
inundation_depth = "1 m"
pump_capacity = "5 m^3/s"

[breach]
growth = "verheij_clay"
max_length = "von_thun_gillette"
development_time = "12 h"
flow = "{flow}"
resolution = "{resolution}"

[methods.split_barge]
capacity = "1000 t/h"
mobilisation = "24 h"

[methods.end_dumping]
capacity = "350 t/h"
working_hours = "16 h"
mobilisation = "12 h"
"""


def main(argv):
    ap = argparse.ArgumentParser(prog="bench atlas")
    ap.add_argument("--length", type=float, default=20000.0)
    ap.add_argument("--spacing", default="200 m")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--flow", default="swe")
    ap.add_argument("--resolution", default="8 m")
    ap.add_argument("--check", type=int, default=5, help="locations re-screened at half the cell size")
    ap.add_argument("--reps", type=int, default=1)
    a = ap.parse_args(argv)

    from breachflow.atlas import run_atlas
    from breachflow.atlas.config import parse_district

    spec = importlib.util.spec_from_file_location("make_district", ROOT / "examples" / "district" / "make_district.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_district"] = mod
    spec.loader.exec_module(mod)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        mod.write(tmp, length=a.length)
        path = tmp / "district.toml"
        path.write_text(TOML.format(terrain=tmp / "terrain.tif", levee=tmp / "levee.geojson", spacing=a.spacing,
                                    flow=a.flow, resolution=a.resolution))
        walls, effs = [], []
        for rep in range(a.reps):
            t0 = time.perf_counter()
            ds = run_atlas(path, tmp / f"out{rep}", workers=a.workers, progress=False)
            wall = time.perf_counter() - t0
            cpu = float(ds.solve_cpu_s.sum())
            walls.append(wall)
            effs.append(cpu / (a.workers * wall))
            print(f"rep {rep}: {ds.sizes['location']} locations along {a.length / 1000:g} km, wall {wall:.1f} s, "
                  f"location CPU {cpu:.1f} s, efficiency {effs[-1]:.2f}", flush=True)
        sd = lambda v: statistics.stdev(v) if len(v) > 1 else 0.0  # noqa: E731
        print(f"wall {statistics.mean(walls):.1f} ± {sd(walls):.1f} s; scheduling efficiency "
              f"{statistics.mean(effs):.2f} ± {sd(effs):.2f} on {a.workers} workers")
        if a.check and a.flow == "swe":
            from breachflow.atlas.execute import plan
            from breachflow.atlas.locations import load_inputs as _inputs
            from breachflow.atlas.screening import screen

            import dataclasses

            district, locs = plan(path)
            fine = dataclasses.replace(district, resolution=district.resolution / 2)
            terrain, levee = _inputs(str(district.terrain), str(district.levee), None, None)
            step = max(1, len(locs) // a.check)
            rel = []
            for loc in locs[::step][:a.check]:
                q0 = float(ds.open_discharge_m3s.values[loc.index])
                q1 = screen(loc, fine, terrain=terrain, levee=levee)["open_discharge_m3s"]
                rel.append((q0 - q1) / q1)
            print(f"open-breach discharge at {district.resolution:g} m against {fine.resolution:g} m cells "
                  f"({len(rel)} locations): {100 * statistics.mean(rel):+.1f} % mean, "
                  f"{100 * min(rel):+.1f} to {100 * max(rel):+.1f} %")
    return 0
