"""The typical breach to its verdict, CPU time per start of the first solve, with the error figure.

    python3 tasks.py bench verdict [--resolution 2] [--starts cold,coarse] [--seed 1] [--parallel]
                                   [--reference-tolerance 2e-5] [--reference-t-max 1800] [--json FILE]

``examples/typical_breach.toml`` at ``--resolution`` m runs to its verdict once per ``[hydro] cold_start``
of ``--starts`` (``cold``: the first solve from the initial state on the run's grid, the shipped path;
``coarse``: from the steady state of a grid twice as coarse, :mod:`breachflow.hydro.coarse_start`), each
in a fresh child process (``time.process_time`` of the child: CPU seconds, not wall, on a shared
machine). Printed per start: the total CPU time, that of the first solve and of the warm re-solves, the
verdict, cycles, tonnage, the open breach's discharge and depth-weighted gap speed; then each start's CPU
times as a ratio to the first start's (same command, same machine state), and the difference of its open
breach discharge and gap speed from the first start's.

With ``--reference-tolerance`` the open breach alone is also solved cold at that steady-state tolerance
(1/s; ``t_max_initial`` ``--reference-t-max`` s) as the tight-tolerance reference, and every start's
open-breach discharge and gap speed are given as differences from it.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child(scenario: str, out: str, result: str, only_first: bool) -> None:
    c0 = time.process_time()
    if only_first:
        from breachflow.cycle.config import closure_setup
        from breachflow.cycle.criteria import gap_section_speeds, section_discharge
        from breachflow.scenario import load_scenario

        setup = closure_setup(load_scenario(scenario))
        snap = setup.solver.solve(setup.domain)
        gmax, gmean = gap_section_speeds(snap, setup.breach_x, setup.levee_y)
        r = {"q0": section_discharge(snap, setup.breach_x, setup.levee_y), "gap0": gmean, "gapmax0": gmax,
             "t": float(snap.attrs.get("simulated_time_s", float("nan"))),
             "converged": int(snap.attrs.get("steady_state", 0))}
    else:
        from breachflow.cycle.main import run_closure

        res = run_closure(scenario, out, overwrite=True, plots=False)
        man = json.loads((Path(out) / "manifest.json").read_text())
        ini = man["metadata"]["initial"]
        cyc = [c["summary"] for c in man["cycles"]]
        r = {"closed": res.closed, "verdict": res.verdict, "cycles": res.cycles, "tonnage": res.tonnage,
             "lost_t": res.lost_tonnage, "q0": ini["breach_discharge"], "gap0": ini["gap_mean_speed"],
             "gapmax0": ini["gap_max_speed"], "first_cpu": ini["solve_cpu_time"],
             "resolve_cpu": sum(c.get("cpu_solve", 0.0) for c in cyc), "dem_cpu": sum(c.get("cpu_dem", 0.0) for c in cyc)}
    r["cpu"] = time.process_time() - c0
    Path(result).write_text(json.dumps(r))


def scenario_text(res: float, seed: int, start: str, tolerance: float | None = None, t_max: float | None = None) -> str:
    text = (ROOT / "examples" / "typical_breach.toml").read_text(encoding="utf-8")
    text = re.sub(r'^resolution = "[^"]*"', f'resolution = "{res:g} m"', text, flags=re.M)
    text = re.sub(r'^seed = [0-9]+', f"seed = {seed}", text, flags=re.M)
    text = re.sub(r'^cold_start = .*\n', "", text, flags=re.M)
    extra = f'cold_start = "{start}"\n'
    if tolerance is not None:
        text = re.sub(r'^(tolerance|t_max_initial) = .*\n', "", text, flags=re.M)
        extra += f'tolerance = "{tolerance:g} 1/s"\nt_max_initial = "{t_max:g} s"\n'
    return text.replace("[hydro]\n", "[hydro]\n" + extra, 1)


def start_child(work: Path, tag: str, text: str, only_first: bool = False):
    """Start one child process; returns ``(process, result file, start time)``."""
    sc = work / f"{tag}.toml"
    sc.write_text(text, encoding="utf-8")
    rfile = work / f"{tag}.json"
    proc = subprocess.Popen([sys.executable, __file__, "--child", str(sc), str(work / f"run_{tag}"), str(rfile),
                             "1" if only_first else "0"])
    return proc, rfile, time.perf_counter()


def finish_child(job) -> dict:
    proc, rfile, w0 = job
    if proc.wait() != 0:
        raise SystemExit(f"child {rfile.stem} failed (exit code {proc.returncode})")
    r = json.loads(rfile.read_text())
    r["wall"] = time.perf_counter() - w0
    return r


def main(argv) -> int:
    if argv and argv[0] == "--child":
        child(argv[1], argv[2], argv[3], argv[4] == "1")
        return 0
    ap = argparse.ArgumentParser(prog="bench verdict")
    ap.add_argument("--resolution", type=float, default=2.0)
    ap.add_argument("--starts", default="cold,coarse")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--reference-tolerance", type=float, default=None)
    ap.add_argument("--reference-t-max", type=float, default=1800.0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--parallel", action="store_true", help="run the children at the same time (CPU times are "
                    "per child; on a loaded machine this shortens the wall time)")
    a = ap.parse_args(argv)
    starts = [s.strip() for s in a.starts.split(",") if s.strip()]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        jobs = {}
        for s in starts:
            jobs[s] = start_child(work, f"verdict_{s}", scenario_text(a.resolution, a.seed, s))
            if not a.parallel:
                jobs[s] = finish_child(jobs[s])
        ref_job = None
        if a.reference_tolerance:
            ref_job = start_child(work, "reference", scenario_text(a.resolution, a.seed, "cold", a.reference_tolerance,
                                                                   a.reference_t_max), only_first=True)
        for s in starts:
            rows[s] = jobs[s] if isinstance(jobs[s], dict) else finish_child(jobs[s])
            r = rows[s]
            print(f"{a.resolution:g} m, seed {a.seed}, cold_start {s}: CPU {r['cpu']:.1f} s (first solve "
                  f"{r['first_cpu']:.1f}, re-solves {r['resolve_cpu']:.1f}, DEM {r['dem_cpu']:.1f}), wall {r['wall']:.0f} s; "
                  f"{'closed' if r['closed'] else r['verdict'] or 'not closed'} after {r['cycles']} cycles, "
                  f"{r['tonnage']:,.0f} t placed, {r['lost_t']:,.0f} t lost; open breach Q {r['q0']:.2f} m3/s, "
                  f"gap speed {r['gap0']:.4f} mean / {r['gapmax0']:.4f} max m/s", flush=True)
        ref = None
        if ref_job is not None:
            ref = finish_child(ref_job)
            print(f"reference (cold, tolerance {a.reference_tolerance:g} 1/s, t_max {a.reference_t_max:g} s, "
                  f"{'converged' if ref['converged'] else 'NOT converged'} at t = {ref['t']:.0f} s): Q {ref['q0']:.2f} "
                  f"m3/s, gap speed {ref['gap0']:.4f} m/s, CPU {ref['cpu']:.1f} s", flush=True)
    base = rows[starts[0]]
    print(f"\nratios to cold_start {starts[0]!r} (same command):")
    for s, r in rows.items():
        line = (f"  {s:7s} CPU total {r['cpu'] / base['cpu']:.3f}, first solve {r['first_cpu'] / base['first_cpu']:.3f}, "
                f"re-solves {r['resolve_cpu'] / base['resolve_cpu']:.3f}" if base['resolve_cpu'] > 0 else "")
        line += (f"; open breach Q {100 * (r['q0'] / base['q0'] - 1):+.3f} %, gap speed "
                 f"{100 * (r['gap0'] / base['gap0'] - 1):+.3f} %")
        if ref is not None:
            line += (f"; against the reference: Q {100 * (r['q0'] / ref['q0'] - 1):+.3f} %, gap speed "
                     f"{100 * (r['gap0'] / ref['gap0'] - 1):+.3f} %")
        print(line)
    if a.json:
        Path(a.json).write_text(json.dumps({"runs": rows, "reference": ref, "args": vars(a)}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
