"""Shallow-water solver benchmark: ``python3 tasks.py bench swe [options]``.

1. Cell updates per second per core (one numba thread, CPU time) for first and second order on
   10^4 … 10^6 cells (a wet dam break with Manning friction), plus the 2-thread rate.
2. Wall and CPU time to steady state of the report's typical breach at 4 m and 2 m, from a cold start
   and warm-started from the coarser steady state (grid sequencing), with the peak speeds.
3. ANUGA side by side on the Stoker dam break (100 m × 5 m channel, h 1.0 | 0.1 m, 5 s) at equal cell
   (triangle) counts: L1 depth error and wall time of both, as ratios. ANUGA runs in a subprocess of
   its own venv ``.venv-bench-anuga`` (created on demand with ``pip install anuga``).

Options: ``--sizes 1e4,1e5,1e6`` ``--threads 1,2`` ``--breach 8,4,2`` (empty to skip) ``--monitor-radius``
``--breach-threads`` ``--no-sequence``
``--anuga-cells 2000,8000,32000`` (``--no-anuga`` to skip) ``--t-max 3600`` ``--tolerance 1e-4``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ANUGA_VENV = ROOT / ".venv-bench-anuga"


def _table(title, header, rows):
    try:
        from rich.console import Console
        from rich.table import Table

        t = Table(title=title)
        for h in header:
            t.add_column(h, justify="right")
        for r in rows:
            t.add_row(*[str(c) for c in r])
        Console(width=200).print(t)
    except ImportError:  # pragma: no cover
        print(title)
        print(" | ".join(header))
        for r in rows:
            print(" | ".join(map(str, r)))


# ------------------------------------------------------------------ 1. throughput
def throughput(sizes, min_cpu=2.0, thread_counts=(1,)):
    from breachflow.hydro.swe import SWEOptions, SWESimulation
    from breachflow.hydro.terrain import uniform_grid

    rows = []
    for n_cells in sizes:
        n = int(round(math.sqrt(n_cells)))
        dom = uniform_grid(0, n, 0, n, 1.0, manning=0.02,
                           initial_surface=lambda X, Y: np.where(X + 0.3 * Y < 0.6 * n, 2.0, 1.0),
                           bed=lambda X, Y: 0.1 * np.sin(X / 7.0) * np.cos(Y / 5.0))
        rates = {}
        for order in (1, 2):
            for threads in thread_counts:
                sim = SWESimulation(dom, SWEOptions(order=order, threads=threads))
                sim.advance_to(1e9, max_steps=2)  # compile / warm up
                steps = 0
                cpu0, wall0 = time.process_time(), time.perf_counter()
                while time.process_time() - cpu0 < min_cpu or steps < 5:
                    s0 = sim.steps
                    sim.advance_to(1e9, max_steps=5)
                    steps += sim.steps - s0
                cpu = time.process_time() - cpu0
                wall = time.perf_counter() - wall0
                rates[(order, threads)] = (n * n * steps / cpu, n * n * steps / wall)
        r1, r2 = rates[(1, 1)][0], rates[(2, 1)][0]
        row = [f"{n * n:.1e}", f"{r1 / 1e6:.2f}", f"{r2 / 1e6:.2f}", f"{r2 / r1:.2f}"]
        for k in thread_counts[1:]:
            row += [f"{rates[(1, k)][1] / 1e6:.2f}", f"{rates[(2, k)][1] / 1e6:.2f}"]
        rows.append(row)
    header = ["cells", "1st order M/s/core (CPU)", "2nd order M/s/core (CPU)", "ratio 2nd/1st"]
    for k in thread_counts[1:]:
        header += [f"1st order M/s {k} threads (wall)", f"2nd order M/s {k} threads (wall)"]
    _table("cell updates per second (one time step of one cell; second order = 2 RK stages)", header, rows)
    return rows


# ------------------------------------------------------------------ 2. typical breach
def typical_breach_runs(resolutions, t_max, tolerance, monitor_radius=None, threads=1, sequence=True):
    """Each resolution from a cold start (flood side at the source level, polder dry) and, with
    *sequence*, also warm-started from the steady state of the previous (coarser) resolution."""
    from breachflow.hydro.derived import peak_speed
    from breachflow.hydro.swe import SWEOptions, SWESimulation
    from breachflow.hydro.terrain import breach_domain, breach_vicinity
    from breachflow.scenario import typical_breach

    scene = typical_breach()
    radius = monitor_radius if monitor_radius else 2.0 * scene.breach.length
    rows = []
    out = []
    previous = None
    for res in resolutions:
        dom = breach_domain(scene, res)
        starts = [("cold", None)] + ([(f"from {previous[0]:g} m", previous[1])] if sequence and previous else [])
        for label, initial in starts:
            sim = SWESimulation(dom, SWEOptions(order=2, threads=threads), initial=initial)
            cpu0, wall0 = time.process_time(), time.perf_counter()
            hist = sim.run_to_steady(tolerance, t_max, region=breach_vicinity(dom, scene, radius))
            cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
            ds = sim.snapshot()
            pk = peak_speed(ds)
            near = peak_speed(ds, x_range=(-scene.breach.length, scene.breach.length), y_range=(-50.0, 50.0))
            ic = int(np.argmin(np.abs(ds.x.values)))
            jc = int(np.argmin(np.abs(ds.y.values)))
            centre = float(ds.speed.values[jc, ic])
            breach_cols = np.abs(ds.x.values) < 0.5 * scene.breach.length
            q = float(ds.v.values[jc, breach_cols] @ ds.depth.values[jc, breach_cols]) * sim.dx
            rows.append([f"{res:g} m", label, f"{dom.shape[1]}×{dom.shape[0]}", f"{sim.t:.0f}", str(sim.steps),
                         "yes" if hist.converged else "no", f"{wall:.1f}", f"{cpu:.1f}",
                         f"{pk['speed']:.2f} @ ({pk['x']:.0f}, {pk['y']:.0f})",
                         f"{near['speed']:.2f} @ ({near['x']:.0f}, {near['y']:.0f})", f"{centre:.2f}", f"{q:.0f}"])
            if label == "cold":
                cold_wall = wall
            else:
                rows[-1][6] += f" ({cold_wall / wall:.1f}× faster)"
            print("[bench swe] typical breach " + " | ".join(rows[-1]), flush=True)
        previous = (res, ds)
        out.append(ds)
    ritter = 2.0 / 3.0 * math.sqrt(9.81 * scene.levee.height)
    _table(f"typical breach to steady state (tolerance {tolerance:g} 1/s within {radius:g} m of the breach, limit "
           f"{t_max:g} s, {threads} thread(s)); report ADH peak ~{scene.notes['adh_peak_velocity_m_s']} m/s near the "
           f"levee centreline, Ritter 2/3 sqrt(g h_L) = {ritter:.2f} m/s",
           ["cells", "start", "grid", "sim time s", "steps", "steady", "wall s", "CPU s",
            "peak speed m/s @ (x, y)", "peak within 50 m of centreline", "speed at breach centre",
            "breach Q m³/s"], rows)
    return out


# ------------------------------------------------------------------ 3. ANUGA
ANUGA_SCRIPT = textwrap.dedent('''
    import json, sys, time, warnings
    import numpy as np
    warnings.filterwarnings("ignore")
    import anuga
    m, n = int(sys.argv[1]), int(sys.argv[2])
    t0 = time.perf_counter(); c0 = time.process_time()
    dom = anuga.rectangular_cross_domain(m, n, len1=100.0, len2=5.0)
    dom.set_flow_algorithm("DE1")
    dom.set_store(False)
    dom.set_quantity("elevation", 0.0)
    dom.set_quantity("friction", 0.0)
    dom.set_quantity("stage", lambda x, y: np.where(x < 50.0, 1.0, 0.1))
    br = anuga.Reflective_boundary(dom)
    dom.set_boundary({"left": br, "right": br, "top": br, "bottom": br})
    t1 = time.perf_counter(); c1 = time.process_time()
    for _ in dom.evolve(yieldstep=5.0, finaltime=5.0):
        pass
    t2 = time.perf_counter(); c2 = time.process_time()
    xy = dom.centroid_coordinates
    h = dom.quantities["stage"].centroid_values - dom.quantities["elevation"].centroid_values
    area = dom.areas
    json.dump({"x": xy[:, 0].tolist(), "h": h.tolist(), "area": area.tolist(), "triangles": int(dom.number_of_triangles),
               "wall_setup": t1 - t0, "wall_evolve": t2 - t1, "cpu_evolve": c2 - c1,
               "algorithm": dom.get_flow_algorithm(), "version": anuga.__version__}, sys.stdout)
''')


def ensure_anuga() -> Path | None:
    py = ANUGA_VENV / "bin" / "python"
    ok = py.exists() and subprocess.run([str(py), "-c", "import anuga"], capture_output=True).returncode == 0
    if not ok:
        print(f"[bench swe] creating {ANUGA_VENV} and installing anuga (about a minute)", flush=True)
        subprocess.run([sys.executable, "-m", "venv", str(ANUGA_VENV)], check=True)
        r = subprocess.run([str(py), "-m", "pip", "install", "-q", "anuga"], capture_output=True, text=True)
        if r.returncode != 0:
            print(f"[bench swe] pip install anuga failed; skipping ANUGA:\n{r.stderr[-2000:]}")
            return None
    return py


def stoker_exact(x, t=5.0, hl=1.0, hr=0.1, x0=50.0, g=9.81):
    from scipy.optimize import brentq

    cl, cr = math.sqrt(g * hl), math.sqrt(g * hr)

    def f(cm):
        hm = cm * cm / g
        s = cr * math.sqrt(0.5 * (hm / hr) * (hm / hr + 1.0))
        return 2.0 * (cl - cm) - s * (1.0 - hr / hm)

    cm = brentq(f, cr * (1 + 1e-12), cl * (1 - 1e-12), xtol=1e-15)
    hm = cm * cm / g
    um = 2.0 * (cl - cm)
    s = um * hm / (hm - hr)
    xi = (np.asarray(x, float) - x0) / t
    return np.where(xi <= -cl, hl, np.where(xi < um - cm, (2 * cl - xi) ** 2 / (9 * g), np.where(xi < s, hm, hr)))


def anuga_comparison(cell_counts):
    from breachflow.hydro.swe import SWEOptions, SWESimulation
    from breachflow.hydro.terrain import uniform_grid

    py = ensure_anuga()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "anuga_stoker.py"
        script.write_text(ANUGA_SCRIPT)
        for cells in cell_counts:
            # ANUGA rectangular_cross: 4 triangles per rectangle of an m × 5 grid over 100 m × 5 m
            n_rect = 5
            m_rect = max(1, cells // (4 * n_rect))
            total = 4 * m_rect * n_rect
            anuga_res = None
            if py is not None:
                r = subprocess.run([str(py), str(script), str(m_rect), str(n_rect)], capture_output=True, text=True,
                                   cwd=tmp, env={**os.environ, "PYTHONWARNINGS": "ignore"})
                if r.returncode != 0:
                    print(r.stderr[-1500:])
                else:
                    a = json.loads(r.stdout.strip().splitlines()[-1])
                    e_a = float(np.sum(np.abs(np.array(a["h"]) - stoker_exact(np.array(a["x"]))) * np.array(a["area"])) / 5.0)
                    anuga_res = (e_a, a["wall_evolve"], a["cpu_evolve"])
                    rows.append([f"{a['triangles']}", f"ANUGA {a['version']} {a['algorithm']}", "triangles",
                                 f"{e_a:.4f}", f"{a['wall_evolve']:.3f}", f"{a['cpu_evolve']:.3f}", "1", "1"])
            # ours at the same cell count: a 1-D layout (nx × 5, fine along the flow) and square cells
            side = math.sqrt(500.0 / total)
            layouts = {"nx × 5": (total // 5, 5), "square": (int(round(100 / side)), max(1, int(round(5 / side))))}
            for name, (nx, ny) in layouts.items():
                dom = uniform_grid(0, 100, 0, 5, 100 / nx, dy=5 / ny,
                                   initial_surface=lambda X, Y: np.where(X < 50.0, 1.0, 0.1))
                for order in (2, 1):
                    SWESimulation(dom, SWEOptions(order=order)).advance_to(1e-6)  # compile outside the timing
                    sim = SWESimulation(dom, SWEOptions(order=order))
                    w0, c0 = time.perf_counter(), time.process_time()
                    sim.advance_to(5.0)
                    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
                    err = float(np.abs(sim.depth - stoker_exact(dom.x)[None, :]).sum() * dom.dx * dom.dy / 5.0)
                    ratios = (["", ""] if anuga_res is None else
                              [f"{anuga_res[0] / err:.2f}", f"{anuga_res[2] / cpu:.2f}"])
                    rows.append([f"{nx * ny}", f"breachflow order {order}", f"{name} ({nx}×{ny})",
                                 f"{err:.4f}", f"{wall:.3f}", f"{cpu:.3f}", *ratios])
    _table("Stoker dam break 100 m × 5 m, h 1.0 | 0.1 m, t = 5 s: L1 depth error (m² per m width), "
           "wall and CPU time of the time loop (s); ratios > 1 favour breachflow",
           ["cells", "solver", "layout", "L1 error", "wall s", "CPU s", "L1 ANUGA/ours", "CPU ANUGA/ours"], rows)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="bench swe", description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="1e4,1e5,1e6")
    p.add_argument("--breach", default="8,4,2", help="typical-breach resolutions in m ('' to skip)")
    p.add_argument("--t-max", type=float, default=3600.0)
    p.add_argument("--tolerance", type=float, default=1e-4)
    p.add_argument("--monitor-radius", type=float, default=None,
                   help="steady state judged within this distance of the breach centre (m; default 2 B)")
    p.add_argument("--breach-threads", type=int, default=1, help="numba threads for the typical-breach runs")
    p.add_argument("--no-sequence", action="store_true", help="typical breach: cold starts only")
    p.add_argument("--anuga-cells", default="2000,8000,32000")
    p.add_argument("--no-anuga", action="store_true")
    p.add_argument("--min-cpu", type=float, default=2.0, help="CPU seconds per throughput measurement")
    p.add_argument("--threads", default="1", help="numba thread counts for the throughput table, e.g. 1,2")
    a = p.parse_args(argv)
    if a.sizes:
        throughput([int(float(s)) for s in a.sizes.split(",")], a.min_cpu, tuple(int(k) for k in a.threads.split(",")))
    if not a.no_anuga and a.anuga_cells:
        anuga_comparison([int(float(s)) for s in a.anuga_cells.split(",")])
    if a.breach:
        typical_breach_runs([float(s) for s in a.breach.split(",")], a.t_max, a.tolerance, a.monitor_radius,
                            a.breach_threads, not a.no_sequence)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
