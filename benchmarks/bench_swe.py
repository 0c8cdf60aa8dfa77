"""Shallow water against ANUGA (Stoker's dam break): CPU time at equal error; cell updates per CPU s.

Shallow-water solver benchmark: ``python3 tasks.py bench swe [options]``.

1. Cell updates per second per core (one numba thread, CPU time) for first and second order on
   10^4 … 10^6 cells (a wet dam break with Manning friction), plus the 2-thread rate.
2. Wall and CPU time to steady state of the report's typical breach at 4 m and 2 m, from a cold start
   and warm-started from the coarser steady state (grid sequencing), with the peak speeds.
3. ANUGA DE1 side by side on the Stoker dam break (100 m × 5 m channel, h 1.0 | 0.1 m, 5 s): L1 depth
   error and CPU time of both, and the CPU-time ratio at equal or smaller L1 (our cheapest run not less
   accurate than ANUGA's), mean ± standard deviation over repeats. ANUGA runs in a subprocess of its own
   venv ``.venv-bench-anuga`` (created on demand with ``pip install anuga``).

Options: ``--sizes 1e4,1e5,1e6`` ``--threads 1,2`` ``--breach 8,4,2`` (empty to skip) ``--monitor-radius``
``--breach-threads`` ``--no-sequence``
``--anuga-cells 32000,128000`` (``--no-anuga`` to skip) ``--reps 3`` ``--fractions 1,0.7,0.5``
``--thread-cells 128000`` (one Stoker solve on 1 and 2 threads) ``--t-max 3600`` ``--tolerance 1e-4``.
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
    from breachflow.swe import SWEOptions, SWESimulation
    from breachflow.swe.domain import uniform_grid

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
    from breachflow.field.derived import peak_speed
    from breachflow.swe import SWEOptions, SWESimulation
    from breachflow.swe.domain import breach_domain, breach_vicinity
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
               "steps": int(dom.number_of_steps),
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


def _run_anuga(py, script, tmp, m_rect, n_rect):
    r = subprocess.run([str(py), str(script), str(m_rect), str(n_rect)], capture_output=True, text=True,
                       cwd=tmp, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    if r.returncode != 0:
        print(r.stderr[-1500:])
        return None
    a = json.loads(r.stdout.strip().splitlines()[-1])
    a["l1"] = float(np.sum(np.abs(np.array(a["h"]) - stoker_exact(np.array(a["x"]))) * np.array(a["area"])) / 500.0)
    return a


def _run_ours(cells, threads=1):
    """Second order on square cells, *cells* about the given count; returns (cells, L1 m, CPU s, wall s)."""
    from breachflow.swe import SWEOptions, SWESimulation
    from breachflow.swe.domain import uniform_grid

    side = math.sqrt(500.0 / cells)
    nx, ny = int(round(100 / side)), max(1, int(round(5 / side)))
    dom = uniform_grid(0, 100, 0, 5, 100 / nx, dy=5 / ny, initial_surface=lambda X, Y: np.where(X < 50.0, 1.0, 0.1))
    opts = SWEOptions(order=2, threads=threads)
    SWESimulation(dom, opts).advance_to(1e-6)  # compile outside the timing
    sim = SWESimulation(dom, opts)
    w0, c0 = time.perf_counter(), time.process_time()
    sim.advance_to(5.0)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    err = float(np.abs(sim.depth - stoker_exact(dom.x)[None, :]).sum() * dom.dx * dom.dy / 500.0)
    return nx * ny, err, cpu, wall, sim.steps


def _mean_sd(v):
    v = list(v)
    m = sum(v) / len(v)
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else float("nan")
    return m, sd


def anuga_comparison(cell_counts, reps=3, fractions=(1.0, 0.7, 0.5)):
    """Stoker dam break, ANUGA DE1 on ``rectangular_cross_domain(20 n, n)`` (isotropic triangles, 4 per
    square) against our second order on square cells at *fractions* of ANUGA's triangle count; *reps*
    runs of each, interleaved. The CPU-time ratio is ANUGA's over that of our cheapest run whose L1 error
    is not larger than ANUGA's (mean ± standard deviation over the paired repeats)."""
    py = ensure_anuga()
    rows = []
    summary = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "anuga_stoker.py"
        script.write_text(ANUGA_SCRIPT)
        for cells in cell_counts:
            n_rect = max(1, int(round(math.sqrt(cells / 80.0))))
            m_rect = 20 * n_rect
            anuga_runs, ours = [], {f: [] for f in fractions}
            for _ in range(reps):
                if py is not None:
                    a = _run_anuga(py, script, tmp, m_rect, n_rect)
                    if a is not None:
                        anuga_runs.append(a)
                for f in fractions:
                    ours[f].append(_run_ours(cells * f))
            a_cpu = [a["cpu_evolve"] for a in anuga_runs]
            if anuga_runs:
                a0 = anuga_runs[0]
                m, sd = _mean_sd(a_cpu)
                rows.append([f"{a0['triangles']}", f"ANUGA {a0['version']} {a0['algorithm']}", f"{a0['l1']:.3e}",
                             f"{m:.2f} ± {sd:.2f}", f"{a0['triangles'] * a0.get('steps', 0) / m / 1e6:.2f}"
                             if a0.get("steps") else "", "", ""])
            best = None
            for f in fractions:
                n, err = ours[f][0][0], ours[f][0][1]
                cpu = [r[2] for r in ours[f]]
                m, sd = _mean_sd(cpu)
                steps = ours[f][0][4]
                ratio = ""
                if anuga_runs:
                    rr = [x / y for x, y in zip(a_cpu, cpu)]
                    rm, rsd = _mean_sd(rr)
                    ratio = f"{rm:.2f} ± {rsd:.2f}"
                    if err <= anuga_runs[0]["l1"] and (best is None or m < best[1]):
                        best = (f, m, rm, rsd, n, err)
                rows.append([f"{n}", "breachflow order 2 (square cells)", f"{err:.3e}", f"{m:.2f} ± {sd:.2f}",
                             f"{n * steps / m / 1e6:.2f}", ratio,
                             "yes" if anuga_runs and err <= anuga_runs[0]["l1"] else ""])
            if anuga_runs and best is not None:
                summary.append(f"{anuga_runs[0]['triangles']} triangles: ANUGA DE1 L1 {anuga_runs[0]['l1']:.3e} m, "
                               f"CPU {_mean_sd(a_cpu)[0]:.2f} s; breachflow {best[4]} cells L1 {best[5]:.3e} m, "
                               f"CPU {best[1]:.2f} s: ANUGA/breachflow CPU {best[2]:.2f} ± {best[3]:.2f} "
                               f"(n = {len(a_cpu)}) at equal or smaller L1")
            elif anuga_runs:
                summary.append(f"{anuga_runs[0]['triangles']} triangles: no breachflow run reached ANUGA's L1")
    _table(f"Stoker dam break 100 m × 5 m, h 1.0 | 0.1 m, t = 5 s ({reps} runs each, one thread): L1 depth error "
           "(mean |h - h_exact| over the domain, m), CPU time of the time loop (s), cell-steps per CPU s "
           "(a second-order step is two stages); ratios > 1 favour breachflow",
           ["cells", "solver", "L1 error m", "CPU s", "M cell-steps/CPU s", "CPU ANUGA/ours", "L1 ≤ ANUGA"], rows)
    for line in summary:
        print("[bench swe] " + line, flush=True)
    return rows


def thread_speedup(cells=128000, reps=3):
    """Wall and CPU time of one Stoker solve on 1 and 2 numba threads (interleaved repeats)."""
    runs = {1: [], 2: []}
    for _ in range(reps):
        for k in (1, 2):
            runs[k].append(_run_ours(cells, threads=k))
    w1, w2 = [r[3] for r in runs[1]], [r[3] for r in runs[2]]
    c1, c2 = [r[2] for r in runs[1]], [r[2] for r in runs[2]]
    sw = _mean_sd([a / b for a, b in zip(w1, w2)])
    sc = _mean_sd([b / a for a, b in zip(c1, c2)])
    print(f"[bench swe] Stoker {runs[1][0][0]} cells, L1 {runs[1][0][1]:.3e} m (1 thread) / {runs[2][0][1]:.3e} m "
          f"(2 threads): wall {_mean_sd(w1)[0]:.2f} s → {_mean_sd(w2)[0]:.2f} s, speed-up {sw[0]:.2f} ± {sw[1]:.2f}; "
          f"CPU {_mean_sd(c1)[0]:.2f} s → {_mean_sd(c2)[0]:.2f} s (×{sc[0]:.2f} ± {sc[1]:.2f}), n = {reps}",
          flush=True)


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
    p.add_argument("--anuga-cells", default="32000,128000")
    p.add_argument("--reps", type=int, default=3, help="repeats of each Stoker run (ANUGA and ours)")
    p.add_argument("--fractions", default="1,0.7,0.5",
                   help="our Stoker runs at these fractions of ANUGA's triangle count")
    p.add_argument("--thread-cells", type=float, default=0,
                   help="also time one Stoker solve of this many cells on 1 and 2 threads (0: skip)")
    p.add_argument("--no-anuga", action="store_true")
    p.add_argument("--min-cpu", type=float, default=2.0, help="CPU seconds per throughput measurement")
    p.add_argument("--threads", default="1", help="numba thread counts for the throughput table, e.g. 1,2")
    a = p.parse_args(argv)
    if a.sizes:
        throughput([int(float(s)) for s in a.sizes.split(",")], a.min_cpu, tuple(int(k) for k in a.threads.split(",")))
    if not a.no_anuga and a.anuga_cells:
        anuga_comparison([int(float(s)) for s in a.anuga_cells.split(",")], a.reps,
                         tuple(float(f) for f in a.fractions.split(",")))
    if a.thread_cells:
        thread_speedup(int(a.thread_cells), a.reps)
    if a.breach:
        typical_breach_runs([float(s) for s in a.breach.split(",")], a.t_max, a.tolerance, a.monitor_radius,
                            a.breach_threads, not a.no_sequence)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
