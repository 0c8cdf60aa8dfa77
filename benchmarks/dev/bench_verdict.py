"""The typical breach to its verdict, the CPU time of each solver path, with the error figures.

    python3 tasks.py bench verdict [--resolution 2] [--paths cold:full,cold:region] [--seed 1] [--parallel]
                                   [--reference-tolerance 2e-4] [--reference-t-max 600] [--json FILE]

``examples/typical_breach.toml`` at ``--resolution`` m runs to its verdict once per path of ``--paths``
(``START:RESOLVE``: ``[hydro] cold_start`` ``cold`` — the first solve from the initial state on the
run's grid — or ``coarse`` — from the steady state of a grid twice as coarse,
:mod:`breachflow.hydro.coarse_start`; ``[hydro] resolve`` ``full`` — the warm re-solve over the whole
domain — or ``region`` — only a region around the changed cells, :mod:`breachflow.hydro.resolve_region`).
The first path is the shipped one (``cold:full``). Each run is a fresh child process
(``time.process_time`` of the child: CPU seconds, not wall, on a shared machine). Printed per path: the
total CPU time, that of the first solve, of the warm re-solves and of the DEM, the verdict, cycles,
tonnage, the open breach's discharge and depth-weighted gap speed, and the same after cycle 1's re-solve;
then each path's CPU times as a ratio to the first path's (same command, same machine state).

The warm re-solve compared on one input. The first path's run records the input of its first warm re-solve
(the domain after cycle 1's remap, the pile, the previous steady state); after its closure the same
child re-solves that input once with each resolve of ``--paths`` at the shipped tolerance and, with
``--reference-tolerance``, with the full re-solve at that tolerance (1/s; ``t_max`` ``--reference-t-max``
s) as the tight-tolerance reference. Printed: each re-solve's CPU time as a ratio to the shipped one's (in
the same process), and its breach discharge and gap speed as differences from the reference. With
``--reference-tolerance`` the open breach alone is also solved cold at that tolerance (not with
``--no-open-reference``), and every path's open breach is given as a difference from it.
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

ROOT = Path(__file__).resolve().parents[2]


def _gap(snap, setup):
    from breachflow.cycle.criteria import gap_section_speeds, section_discharge

    gmax, gmean = gap_section_speeds(snap, setup.breach_x, setup.levee_y)
    return section_discharge(snap, setup.breach_x, setup.levee_y), gmean, gmax


def child_first(scenario: str, result: str) -> dict:
    """The open breach alone (the first solve)."""
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario import load_scenario

    setup = closure_setup(load_scenario(scenario))
    snap = setup.solver.solve(setup.domain)
    q, gmean, gmax = _gap(snap, setup)
    return {"q0": q, "gap0": gmean, "gapmax0": gmax, "t": float(snap.attrs.get("simulated_time_s", float("nan"))),
            "converged": int(snap.attrs.get("steady_state", 0))}


def child_closure(scenario: str, out: str, compare: str) -> dict:
    """The closure to its verdict; with *compare* (JSON: tag -> scenario path), its first warm re-solve's input
    (the domain after cycle 1's remap, the pile, the previous steady state) re-solved afterwards, in this
    process, once per scenario of *compare*."""
    from breachflow.cycle.main import run_closure

    recorded = {}
    if compare:
        from breachflow.swe.solver import SWESolver

        solve = SWESolver.solve

        def recording(self, domain, obstacles=None, initial=None):
            if initial is not None and not recorded:
                recorded.update(domain=domain, obstacles=None if obstacles is None else obstacles.copy(),
                                initial=initial.copy(deep=True))
            return solve(self, domain, obstacles=obstacles, initial=initial)

        SWESolver.solve = recording
    c0 = time.process_time()
    res = run_closure(scenario, out, overwrite=True, plots=False)
    cpu = time.process_time() - c0
    if compare:
        SWESolver.solve = solve
    man = json.loads((Path(out) / "manifest.json").read_text())
    ini = man["metadata"]["initial"]
    cyc = [c["summary"] for c in man["cycles"]]
    r = {"cpu": cpu, "closed": res.closed, "verdict": res.verdict, "cycles": res.cycles, "tonnage": res.tonnage,
         "lost_t": res.lost_tonnage, "q0": ini["breach_discharge"], "gap0": ini["gap_mean_speed"],
         "gapmax0": ini["gap_max_speed"], "first_cpu": ini["solve_cpu_time"],
         "resolve_cpu": sum(c.get("cpu_solve", 0.0) for c in cyc), "dem_cpu": sum(c.get("cpu_dem", 0.0) for c in cyc),
         "q1": cyc[0]["breach_discharge"] if cyc else float("nan"),
         "gap1": cyc[0]["gap_mean_speed"] if cyc else float("nan"),
         "hydro1": cyc[0].get("hydro", "") if cyc else ""}
    if compare and recorded:
        r["resolves"] = resolve_each(json.loads(compare), recorded)
    return r


def resolve_each(scenarios: dict, inp: dict) -> dict:
    """Re-solve the recorded input *inp* once per scenario of *scenarios* (tag -> scenario path)."""
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario import load_scenario

    out = {}
    for tag, path in scenarios.items():
        setup = closure_setup(load_scenario(path))
        c0 = time.process_time()
        snap = setup.solver.solve(inp["domain"], obstacles=inp["obstacles"], initial=inp["initial"])
        cpu = time.process_time() - c0
        q, gmean, gmax = _gap(snap, setup)
        out[tag] = {"cpu": cpu, "q": q, "gap": gmean, "gapmax": gmax,
                    "t": float(snap.attrs.get("simulated_time_s", float("nan"))),
                    "converged": int(snap.attrs.get("steady_state", 0)),
                    "region": str(snap.attrs.get("hydro_region", ""))}
    return out


def child(mode: str, args: list[str], result: str) -> None:
    c0 = time.process_time()
    r = child_first(args[0], result) if mode == "first" else child_closure(args[0], args[1], args[2])
    r["cpu_total"] = time.process_time() - c0
    r.setdefault("cpu", r["cpu_total"])
    Path(result).write_text(json.dumps(r))


def scenario_text(res: float, seed: int, start: str, resolve: str = "full", tolerance: float | None = None,
                  t_max: float | None = None) -> str:
    text = (ROOT / "examples" / "typical_breach.toml").read_text(encoding="utf-8")
    text = re.sub(r'^resolution = "[^"]*"', f'resolution = "{res:g} m"', text, flags=re.M)
    text = re.sub(r'^seed = [0-9]+', f"seed = {seed}", text, flags=re.M)
    text = re.sub(r'^(cold_start|resolve) = .*\n', "", text, flags=re.M)
    extra = f'cold_start = "{start}"\nresolve = "{resolve}"\n'
    if tolerance is not None:
        text = re.sub(r'^(tolerance|t_max_initial|t_max) = .*\n', "", text, flags=re.M)
        extra += f'tolerance = "{tolerance:g} 1/s"\nt_max_initial = "{t_max:g} s"\nt_max = "{t_max:g} s"\n'
    return text.replace("[hydro]\n", "[hydro]\n" + extra, 1)


def start_child(work: Path, tag: str, mode: str, args: list[str]):
    """Start one child process; returns ``(process, result file, start time)``."""
    rfile = work / f"{tag}.json"
    proc = subprocess.Popen([sys.executable, __file__, "--child", mode, str(rfile), *args])
    return proc, rfile, time.perf_counter()


def write_scenario(work: Path, tag: str, text: str) -> str:
    sc = work / f"{tag}.toml"
    sc.write_text(text, encoding="utf-8")
    return str(sc)


def finish_child(job, others=()) -> dict:
    proc, rfile, w0 = job
    if proc.wait() != 0:
        for other in others:  # they would run on in a removed temporary folder
            if not isinstance(other, dict):
                other[0].kill()
        raise SystemExit(f"child {rfile.stem} failed (exit code {proc.returncode})")
    r = json.loads(rfile.read_text())
    r["wall"] = time.perf_counter() - w0
    return r


def _pct(a: float, b: float) -> str:
    return f"{100 * (a / b - 1):+.3f} %"


def main(argv) -> int:
    if argv and argv[0] == "--child":
        child(argv[1], argv[3:], argv[2])
        return 0
    ap = argparse.ArgumentParser(prog="bench verdict")
    ap.add_argument("--resolution", type=float, default=2.0)
    ap.add_argument("--paths", default="cold:full,cold:region",
                    help="START:RESOLVE per closure run, the shipped path first (START cold|coarse, RESOLVE full|region)")
    ap.add_argument("--starts", default=None, help="old form: START,... each with the full re-solve")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--reference-tolerance", type=float, default=None)
    ap.add_argument("--reference-t-max", type=float, default=600.0)
    ap.add_argument("--no-open-reference", action="store_true", help="with --reference-tolerance: only the "
                    "re-solve reference, not the open breach's cold solve at that tolerance")
    ap.add_argument("--json", default=None)
    ap.add_argument("--parallel", action="store_true", help="run the closures at the same time (CPU times are "
                    "per child; on a loaded machine this shortens the wall time)")
    a = ap.parse_args(argv)
    spec = a.paths if a.starts is None else ",".join(f"{s.strip()}:full" for s in a.starts.split(",") if s.strip())
    paths = []
    for p in spec.split(","):
        start, _, resolve = p.strip().partition(":")
        paths.append((start, resolve or "full"))
    names = [f"{s}:{r}" for s, r in paths]
    resolves = list(dict.fromkeys(r for _, r in paths))
    rows, res_rows, ref = {}, None, None
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        scen = {rv: write_scenario(work, f"resolve_{rv}", scenario_text(a.resolution, a.seed, "cold", rv))
                for rv in resolves}
        if a.reference_tolerance:
            scen["reference"] = write_scenario(work, "resolve_reference", scenario_text(
                a.resolution, a.seed, "cold", "full", a.reference_tolerance, a.reference_t_max))
        jobs = {}
        for k, (s, r) in enumerate(paths):
            sc = write_scenario(work, f"verdict_{s}_{r}", scenario_text(a.resolution, a.seed, s, r))
            jobs[names[k]] = start_child(work, f"verdict_{s}_{r}", "closure",
                                         [sc, str(work / f"run_{s}_{r}"), json.dumps(scen) if k == 0 else ""])
            if not a.parallel:
                jobs[names[k]] = finish_child(jobs[names[k]])
        ref_job = None
        if a.reference_tolerance and not a.no_open_reference:
            sc = write_scenario(work, "reference", scenario_text(a.resolution, a.seed, "cold", "full",
                                                                 a.reference_tolerance, a.reference_t_max))
            ref_job = start_child(work, "reference", "first", [sc])
        for name in names:
            rows[name] = jobs[name] if isinstance(jobs[name], dict) else finish_child(
                jobs[name], [*jobs.values(), *([ref_job] if ref_job else [])])
            r = rows[name]
            print(f"{a.resolution:g} m, seed {a.seed}, {name}: CPU {r['cpu']:.1f} s (first solve "
                  f"{r['first_cpu']:.1f}, re-solves {r['resolve_cpu']:.1f}, DEM {r['dem_cpu']:.1f}), wall {r['wall']:.0f} s; "
                  f"{'closed' if r['closed'] else r['verdict'] or 'not closed'} after {r['cycles']} cycles, "
                  f"{r['tonnage']:,.0f} t placed, {r['lost_t']:,.0f} t lost; open breach Q {r['q0']:.2f} m3/s, "
                  f"gap speed {r['gap0']:.4f} mean / {r['gapmax0']:.4f} max m/s; after cycle 1's re-solve Q "
                  f"{r['q1']:.2f} m3/s, gap speed {r['gap1']:.4f} m/s ({r['hydro1']})", flush=True)
        res_rows = rows[names[0]].get("resolves")
        if ref_job is not None:
            ref = finish_child(ref_job)
            print(f"reference open breach (cold, tolerance {a.reference_tolerance:g} 1/s, t_max {a.reference_t_max:g} s, "
                  f"{'converged' if ref['converged'] else 'NOT converged'} at t = {ref['t']:.0f} s): Q {ref['q0']:.2f} "
                  f"m3/s, gap speed {ref['gap0']:.4f} m/s, CPU {ref['cpu']:.1f} s", flush=True)
    base = rows[names[0]]
    print(f"\nclosures, ratios to {names[0]!r} (same command):")
    for name, r in rows.items():
        line = f"  {name:13s} CPU total {r['cpu'] / base['cpu']:.3f}, first solve {r['first_cpu'] / base['first_cpu']:.3f}"
        if base["resolve_cpu"] > 0:
            line += f", re-solves {r['resolve_cpu'] / base['resolve_cpu']:.3f}"
        line += f"; open breach Q {_pct(r['q0'], base['q0'])}, gap speed {_pct(r['gap0'], base['gap0'])}"
        line += f"; after cycle 1 Q {_pct(r['q1'], base['q1'])}, gap speed {_pct(r['gap1'], base['gap1'])}"
        if ref is not None:
            line += f"; open breach against the reference: Q {_pct(r['q0'], ref['q0'])}, gap speed {_pct(r['gap0'], ref['gap0'])}"
        print(line)
    if res_rows:
        shipped = res_rows[resolves[0]]
        refr = res_rows.get("reference")
        print(f"\ncycle 1's warm re-solve, one input re-solved in one process (ratios to resolve {resolves[0]!r}):")
        for tag, r in res_rows.items():
            line = (f"  {tag:9s} CPU {r['cpu']:.1f} s (ratio {r['cpu'] / shipped['cpu']:.3f}), simulated {r['t']:.1f} s "
                    f"{'converged' if r['converged'] else 'NOT converged'}; Q {r['q']:.2f} m3/s, gap speed {r['gap']:.4f} m/s")
            if refr is not None and tag != "reference":
                line += f"; against the reference: Q {_pct(r['q'], refr['q'])}, gap speed {_pct(r['gap'], refr['gap'])}"
            print(line + (f" [{r['region']}]" if r["region"] else ""))
    fastest = min(rows, key=lambda n: rows[n]["cpu"])
    target = (f" (target at 2 m: under 60 CPU s, {'met' if base['cpu'] < 60 else 'not met'}; fastest path {fastest} "
              f"{rows[fastest]['cpu']:.1f} CPU s, {'met' if rows[fastest]['cpu'] < 60 else 'not met'})"
              if a.resolution == 2 else "")
    print(f"\nthe shipped path ({names[0]}) to its verdict at {a.resolution:g} m: {base['cpu']:.1f} CPU s{target}")
    if a.json:
        Path(a.json).write_text(json.dumps({"runs": rows, "resolves": res_rows, "reference": ref, "args": vars(a)},
                                           indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
