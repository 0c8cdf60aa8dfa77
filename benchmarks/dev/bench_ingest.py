"""Ingest benchmark: an ADH-format mesh with ~10^6 nodes and 10 time steps of depth and velocity.

    python benchmarks/run.py ingest [--side 1000] [--steps 10] [--repeat 3] [--dir DIR]

Generates (once, cached in DIR) ``bench.3dm``, ``bench_dep.dat``, ``bench_vel.dat`` and ``bench.bc`` the
way ADH writes them (elements before nodes, ``%16.8e`` values, ``vx vy 0`` vectors), then reads them
with ``open_snapshot`` in a fresh process, reporting wall time, peak memory above the import baseline,
and the size of the resulting Dataset. The baseline measured in the same run is the floor of any text
reader: reading each file whole and converting every number with one ``np.fromstring`` call (no
structure, no checks; it holds a whole file in memory, which the chunked reader avoids).

The writer is measured the same way: ``write_adh`` of the snapshot just read, against ``np.savetxt`` of
the same arrays in the same formats (what a user would write by hand), in the same process.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CHILD = r"""
import json, resource, sys, time, warnings
from pathlib import Path
import breachflow.field as h
from breachflow.io import open_snapshot
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
d = Path(sys.argv[1])
t0 = time.perf_counter()
ds = open_snapshot([d / "bench.3dm", d / "bench_dep.dat", d / "bench_vel.dat", d / "bench.bc"])
t1 = time.perf_counter()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"seconds": t1 - t0, "base_kib": base, "peak_kib": peak, "nbytes": int(ds.nbytes),
                  "nodes": ds.sizes["node"], "faces": ds.sizes["face"], "steps": ds.sizes["time"],
                  "depth_max": float(ds.depth.max())}))
"""

WRITE = r"""
import json, sys, tempfile, time, warnings
import numpy as np
from pathlib import Path
from breachflow.io import open_snapshot, write_adh
from breachflow.field.snapshot import mesh_face_nodes, node_coordinates
d = Path(sys.argv[1])
ds = open_snapshot([d / "bench.3dm", d / "bench_dep.dat", d / "bench_vel.dat", d / "bench.bc"])
out = Path(tempfile.mkdtemp())
x, y = node_coordinates(ds)
f = mesh_face_nodes(ds) + 1
ours, base = [], []
for rep in range(int(sys.argv[2])):  # alternate the two, so load changes hit both
    t0 = time.perf_counter()
    write_adh(ds, out / "w")
    t1 = time.perf_counter()
    with open(out / "s.3dm", "w") as fh:
        np.savetxt(fh, np.column_stack([np.arange(1, len(f) + 1), f, np.ones(len(f), int)]), fmt="E3T %d %d %d %d %d")
        np.savetxt(fh, np.column_stack([np.arange(1, x.size + 1), x, y, ds.bed_elevation.values]), fmt="ND %d %.12g %.12g %.12g")
    with open(out / "s_dep.dat", "w") as a, open(out / "s_vel.dat", "w") as b:
        for k in range(ds.sizes["time"]):
            np.savetxt(a, ds.depth.values[k], fmt="%16.8e")
            np.savetxt(b, np.column_stack([ds.u.values[k], ds.v.values[k], np.zeros(x.size)]), fmt="%16.8e %16.8e %16.8e")
    t2 = time.perf_counter()
    ours.append(t1 - t0)
    base.append(t2 - t1)
print(json.dumps({"ours": ours, "savetxt": base}))
"""

FLOOR = r"""
import json, resource, sys, time, warnings
import numpy as np
from pathlib import Path
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
d = Path(sys.argv[1])
t0 = time.perf_counter()
n = 0
for name in ("bench.3dm", "bench_dep.dat", "bench_vel.dat"):
    data = (d / name).read_bytes()
    if name.endswith(".3dm"):
        data = data.replace(b"E3T", b" ").replace(b"ND", b" ").replace(b"MESH2D", b" ")
    else:
        head, _, body = data.partition(b"TS 0")
        data = body.replace(b"TS 0", b" ").replace(b"ENDDS", b" ")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        n += np.fromstring(data, sep=" ").size
    del data
t1 = time.perf_counter()
print(json.dumps({"seconds": t1 - t0, "base_kib": base, "peak_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, "numbers": n}))
"""


def _savetxt(f, fmt: str, arr: np.ndarray, chunk: int = 200_000) -> None:
    for k in range(0, len(arr), chunk):
        part = arr[k:k + chunk]
        f.write(("\n".join(fmt % tuple(r) for r in part.tolist()) + "\n").encode())


def generate(d: Path, side: int, steps: int) -> None:
    """Write an ADH-like case: side x side nodes on a perturbed grid, 2 (side-1)^2 triangles."""
    stamp = d / f".generated-{side}-{steps}"
    if stamp.exists():
        return
    d.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    n = side * side
    j, i = np.divmod(np.arange(n), side)
    x = 500000.0 + 2.0 * i + rng.uniform(-0.3, 0.3, n)
    y = 4170000.0 + 2.0 * j + rng.uniform(-0.3, 0.3, n)
    z = 10.0 - 0.002 * i + 0.5 * np.sin(j / 50.0)
    ii, jj = np.meshgrid(np.arange(side - 1), np.arange(side - 1))
    a = (jj * side + ii).ravel() + 1
    tri = np.concatenate([np.column_stack([a, a + 1, a + side + 1]), np.column_stack([a, a + side + 1, a + side])])
    ne = len(tri)
    with open(d / "bench.3dm", "wb") as f:
        f.write(b"MESH2D\n")
        _savetxt(f, "E3T %d %d %d %d %d", np.column_stack([np.arange(1, ne + 1), tri, 1 + (np.arange(ne) % 3 == 0)]))
        _savetxt(f, "ND %d %.8e %.8e %.8e", np.column_stack([np.arange(1, n + 1), x, y, z]))
    with open(d / "bench_dep.dat", "wb") as fd, open(d / "bench_vel.dat", "wb") as fv:
        for f, name, kind in ((fd, "Depth", "BEGSCL"), (fv, "Depth-Averaged Velocity", "BEGVEC")):
            f.write(f'DATASET\nOBJTYPE "mesh2d"\n{kind}\nND {n}\nNC {ne}\nNAME "{name}"\nTIMEUNITS SECONDS\n'.encode())
        for s in range(steps):
            h = np.maximum(11.0 + 0.05 * s - z + rng.normal(0, 0.01, n), -0.2)
            fd.write(f"TS 0 {3600.0 * s:16.8e}\n".encode())
            _savetxt(fd, "%16.8e", h[:, None])
            u = np.where(h > 0, 0.8 + 0.1 * np.sin(i / 30.0), 0.0)
            v = np.where(h > 0, 0.05 * np.cos(j / 40.0), 0.0)
            fv.write(f"TS 0 {3600.0 * s:16.8e}\n".encode())
            _savetxt(fv, "%16.8e %16.8e %16.8e", np.column_stack([u, v, np.zeros(n)]))
        fd.write(b"ENDDS\n")
        fv.write(b"ENDDS\n")
    (d / "bench.bc").write_text("OP SW2\nMP G 9.81\nTC T0 0.0 0\nEND\n")
    stamp.write_text("ok")


def _child(code: str, d: Path, *extra) -> dict:
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-c", code, str(d), *map(str, extra)], check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench ingest", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--side", type=int, default=1000, help="nodes per side (side^2 nodes; 1000 -> 10^6)")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=3, help="repeats of the write measurement (median and range)")
    ap.add_argument("--dir", type=Path, default=Path(tempfile.gettempdir()) / "breachflow-bench-ingest")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    generate(args.dir, args.side, args.steps)
    gen = time.perf_counter() - t
    size_mb = sum((args.dir / n).stat().st_size for n in ("bench.3dm", "bench_dep.dat", "bench_vel.dat")) / 1e6
    floor = _child(FLOOR, args.dir)
    ours = _child(CHILD, args.dir)
    wr = _child(WRITE, args.dir, args.repeat)
    ratio = np.array(wr["ours"]) / np.array(wr["savetxt"])
    w_ours, w_base = float(np.median(wr["ours"])), float(np.median(wr["savetxt"]))
    values = ours["nodes"] * ours["steps"] * 3 + ours["nodes"] * 3 + ours["faces"] * 3  # depth + u + v, x y z, faces
    peak_mb = (ours["peak_kib"] - ours["base_kib"]) / 1024
    floor_peak = (floor["peak_kib"] - floor["base_kib"]) / 1024
    data_mb = ours["nbytes"] / 1e6
    from rich.console import Console
    from rich.table import Table

    tab = Table(title=f"ADH ingest: {ours['nodes']:,} nodes, {ours['faces']:,} triangles, {ours['steps']} steps "
                      f"({size_mb:.0f} MB of text; generated in {gen:.1f} s)")
    for col in ("reader", "wall time (s)", "s per 10^6 values", "peak RSS above imports (MB)", "time / baseline"):
        tab.add_column(col)
    tab.add_row("baseline: whole files + one np.fromstring", f"{floor['seconds']:.2f}",
                f"{floor['seconds'] / (floor['numbers'] / 1e6):.3f}", f"{floor_peak:.0f}", "1.00")
    tab.add_row("breachflow open_snapshot (adh)", f"{ours['seconds']:.2f}", f"{ours['seconds'] / (values / 1e6):.3f}",
                f"{peak_mb:.0f}", f"{ours['seconds'] / floor['seconds']:.2f}")
    tab.add_row(f"baseline: np.savetxt of the same arrays (write; median of {args.repeat})", f"{w_base:.2f}",
                f"{w_base / (values / 1e6):.3f}", "", "1.00")
    tab.add_row(f"breachflow write_adh (median of {args.repeat}; ratio range)", f"{w_ours:.2f}",
                f"{w_ours / (values / 1e6):.3f}", "", f"{np.median(ratio):.2f} ({ratio.min():.2f}-{ratio.max():.2f})")
    Console(width=200).print(tab)
    print(f"snapshot Dataset: {data_mb:.0f} MB in memory; peak / data = {peak_mb / data_mb:.2f}; "
          f"{values / 1e6:.1f} million values parsed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
