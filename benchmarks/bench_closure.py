"""The typical breach closed end to end: CPU, memory, cycles, tonnage, the time of each part of a cycle.

The report's typical breach closed end to end, timed against the issue-16 targets.

    python3 tasks.py bench closure [--resolutions 4,2] [--scenario examples/typical_breach.toml] [--no-dem]
                                   [--threads N] [--tolerances 2e-3,5e-4,2e-4] [--seeds 1,2,3] [--json FILE]

Each item of ``--resolutions`` is ``RES[/region|/full][+FINE]``: the cell size (m), optionally the warm
re-solve (``[hydro] resolve``, default the scenario's) and a nested fine grid of FINE m around the breach
(``[hydro] refine``), e.g. ``4/region,4+2,2/region`` (``/window``, the former spelling, is read as
``/region`` with a DeprecationWarning).

For each resolution the shipped scenario ``examples/typical_breach.toml`` (61 m breach in a 7.6 m levee,
10-15 t rock by split barges in time, sealed; the figures quoted in docs/performance.md were measured with
the 4 m masses it shipped before) runs in a child process, as ``breachflow run`` would: to closure, to a "not closable"
verdict, or to ``max_cycles``. Printed per resolution: wall and CPU time, peak memory (max RSS), cycles,
masses, tonnage, masses lost, the outcome, and the time per cycle split into re-solve / DEM / output (wall,
from the run's manifest), plus the first (cold) solve. Against the targets: the whole run at 2 m cells
under 10 minutes wall; the 27-member feasibility ensemble overnight (12 h on the 2 cores), projected from
the measured CPU time of one member (27 x CPU / 2 — a projection, not a measurement).

Error figures that go with the speed figures: the open breach's peak gap speed and breach discharge at
each resolution (their change from 4 m to 2 m is the discretisation error of the answer; the report's ADH
peak speed is ~6.1 m/s) and the tonnage each resolution needs.

``--tolerances`` and ``--seeds`` sweep the steady-state tolerance of the SWE solves (``[hydro] tolerance``,
1/s) and the placement seed (``[closure] seed``: the ``line`` strategy's jitter of the drop points): every
resolution runs at every tolerance for every seed, and a table per resolution and tolerance gives the
verdicts, cycles, tonnage in place (placed minus carried away), losses and the open breach's discharge
over the seeds (mean, min-max), so that the tolerance's effect on the closure answer is read against the
spread one placement seed makes. ``--json`` writes every run's figures to a file.

``--no-dem`` skips the DEM measurement: cycle 1 of the embedded default scenario (1 m cells, 5 masses)
stepped three ways in the same process: the fluid forces term by term (``FluidForces(compiled=False)``, the
path before issue 16), the fused fluid-force kernel called once per step from Python
(``DemSimulation.compiled = False``), and many steps per compiled call (:mod:`breachflow.coupling.steploop`,
the default): microseconds per DEM step, the ratios, and the largest difference of the final positions
against the term-by-term path (the error figure: round-off amplified by the contacts; the compiled loop and
the per-step fused path are bit-identical).
"""
from __future__ import annotations

import argparse
import json
import re
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET_2M_WALL = 600.0  # s
NIGHT = 12 * 3600.0  # s
CORES = 2
MEMBERS = 27


def child(scenario: str, out: str, result: str) -> None:
    """Run one closure in this process and write its resource use to *result* (JSON)."""
    from breachflow.cycle.main import run_closure

    w0, c0 = time.perf_counter(), time.process_time()
    res = run_closure(scenario, out, overwrite=True, plots=False)
    ru = resource.getrusage(resource.RUSAGE_SELF)
    Path(result).write_text(json.dumps({"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
                                        "maxrss_mb": ru.ru_maxrss / 1024.0, "closed": res.closed,
                                        "verdict": res.verdict}))


def parse_item(item: str):
    """``RES[/region|/full][+FINE]`` → (res, resolve or None, refine or None, label).

    ``/window`` is the former spelling of ``/region`` (the re-solve mode's former name), read as ``/region``
    with a DeprecationWarning."""
    m = re.fullmatch(r"\s*([0-9.]+)(?:/(region|window|full))?(?:\+([0-9.]+))?\s*", item)
    if not m:
        raise SystemExit(f"--resolutions item {item!r}: use RES[/region|/full][+FINE]")
    res, resolve, fine = float(m[1]), m[2], (float(m[3]) if m[3] else None)
    if resolve == "window":
        warnings.warn(f"--resolutions item {item!r}: '/window' is deprecated; write '/region'",
                      DeprecationWarning, stacklevel=2)
        resolve = "region"
    label = f"{res:g} m" + (f"/{resolve}" if resolve else "") + (f"+{fine:g} m" if fine else "")
    return res, resolve, fine, label


def override(text: str, section: str, key: str, value: str, where: str) -> str:
    """*text* with ``[section] key = value`` (replaced, or added at the section's head)."""
    from breachflow.scenario.toml import scenario_with

    try:
        return scenario_with(text, {f"{section}.{key}": value})
    except Exception as exc:  # noqa: BLE001 - a benchmark's input error, named
        raise SystemExit(f"{where}: cannot set [{section}] {key} = {value!r}: {exc}") from exc


def one_resolution(scenario: Path, item: str, work: Path, threads: int | None = None,
                   tolerance: str | None = None, seed: int | None = None) -> dict:
    res_m, resolve, fine, label = parse_item(item)
    text = scenario.read_text(encoding="utf-8")
    text, n = re.subn(r'resolution = "[^"]*"', f'resolution = "{res_m:g} m"', text)
    if n != 1:
        raise SystemExit(f"{scenario}: no single [hydro] resolution to override")
    if tolerance is not None:
        text = override(text, "hydro", "tolerance", f"{float(tolerance):g} 1/s", str(scenario))
    if seed is not None:
        text = override(text, "closure", "seed", int(seed), str(scenario))
    tol_m = re.search(r'^tolerance = "([^"]*)"', text, flags=re.M)
    seed_m = re.search(r'^seed = ([0-9]+)', text, flags=re.M)
    tol_s = tol_m[1] if tol_m else "default"
    seed_v = int(seed_m[1]) if seed_m else None
    text = re.sub(r'^(resolve|refine) = .*\n', "", text, flags=re.M)
    if threads:
        text = re.sub(r'^threads = .*\n', "", text, flags=re.M)
    extra = ((f'resolve = "{resolve}"\n' if resolve else "") + (f'refine = "{fine:g} m"\n' if fine else "")
             + (f"threads = {threads}\n" if threads else ""))
    text = text.replace("[hydro]\n", "[hydro]\n" + extra, 1)
    tag = re.sub(r"[^0-9a-z]+", "_", f"{label} {tol_s} s{seed_v}")
    sc = work / f"typical_{tag}.toml"
    sc.write_text(text, encoding="utf-8")
    out, rfile = work / f"run_{tag}", work / f"res_{tag}.json"
    w0 = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--child", str(sc), str(out), str(rfile)], check=True)
    r = json.loads(rfile.read_text())
    r["wall_total"] = time.perf_counter() - w0  # including interpreter start and imports
    man = json.loads((out / "manifest.json").read_text())
    cyc = [c["summary"] for c in man["cycles"]]
    last = cyc[-1] if cyc else {}
    init = man.get("metadata", {}).get("initial") or man.get("initial") or {}
    if threads:
        label += f" ({threads} threads)"
    r.update(res=res_m, fine=fine or res_m, label=label, cycles=len(cyc), tolerance=tol_s, seed=seed_v,
             q=[c.get("breach_discharge", float("nan")) for c in cyc],
             seepage=[c.get("seepage_discharge", float("nan")) for c in cyc],
             resolves=[c.get("hydro", "") for c in cyc], masses=last.get("masses", 0), tonnage=last.get("tonnage", 0.0),
             lost=last.get("left_domain", 0), lost_t=last.get("lost_tonnage", 0.0),
             solve=[c.get("time_solve", float("nan")) for c in cyc], dem=[c.get("time_dem", float("nan")) for c in cyc],
             output=[c.get("time_output", float("nan")) for c in cyc], first_solve=init.get("solve_wall_time"),
             cpu_solve=[c.get("cpu_solve", float("nan")) for c in cyc], cpu_dem=[c.get("cpu_dem", float("nan")) for c in cyc],
             first_solve_cpu=init.get("solve_cpu_time"), gap0=init.get("gap_speed"), q0=init.get("breach_discharge"),
             vmax0=init.get("max_speed"), governing=last.get("governing", ""), final=man.get("final", {}))
    return r


def _mean(a):
    return sum(a) / len(a) if a else float("nan")


def report(rows) -> None:
    print("\ntypical breach (examples/typical_breach.toml), one run per resolution, this machine now:")
    hdr = ("cells", "tolerance", "seed", "wall s", "CPU s", "max RSS MB", "cycles", "masses", "in place t", "lost",
           "outcome")
    print("  " + " | ".join(f"{h:>10}" for h in hdr))
    for r in rows:
        outcome = "closed (" + r["governing"] + ")" if r["closed"] else (r["verdict"] or "not closed")
        print("  " + " | ".join(f"{v:>10}" for v in (r["label"], r.get("tolerance", ""), str(r.get("seed", "")),
                                                      f"{r['wall_total']:.0f}", f"{r['cpu']:.0f}",
                                                      f"{r['maxrss_mb']:.0f}", r["cycles"], r["masses"],
                                                      f"{r['tonnage']:.0f}", f"{r['lost']} ({r['lost_t']:.0f} t)"))
              + f" | {outcome}")
    print("\nper cycle (wall s and this process's CPU s, mean over cycles; first cold solve separately):")
    for r in rows:
        n = max(r["cycles"], 1)
        tot = sum(r["solve"]) + sum(r["dem"]) + sum(r["output"])
        print(f"  {r['label']}: first solve {r['first_solve'] or float('nan'):.1f} s; per cycle solve "
              f"{_mean(r['solve']):.2f} / DEM {_mean(r['dem']):.2f} / output {_mean(r['output']):.3f} s "
              f"({100 * sum(r['solve']) / max(tot, 1e-9):.0f} / {100 * sum(r['dem']) / max(tot, 1e-9):.0f} / "
              f"{100 * sum(r['output']) / max(tot, 1e-9):.1f} %) over {n} cycles")
        print(f"        CPU: first solve {r['first_solve_cpu'] or float('nan'):.1f} s; per cycle solve "
              f"{_mean(r['cpu_solve']):.2f} / DEM {_mean(r['cpu_dem']):.2f} s")
        fr = [float(m[1]) for w in r.get("resolves", []) for m in [re.search(r"([0-9.]+) % of the domain", w)] if m]
        full = sum("full domain" in w for w in r.get("resolves", []))
        if fr or full:
            print(f"        region re-solves: {len(fr)} (share of the domain {min(fr, default=0):.1f}-"
                  f"{max(fr, default=0):.1f} %), full-domain fall-backs: {full}")
    print("\nerror figures (open breach before the first mass; report's ADH peak ~6.1 m/s, ~1,800 m3/s):")
    for r in rows:
        print(f"  {r['label']}: peak speed {r['vmax0'] or float('nan'):.2f} m/s, gap speed "
              f"{r['gap0'] or float('nan'):.2f} m/s, breach discharge {r['q0'] or float('nan'):.0f} m3/s, "
              f"tonnage in place {r['tonnage']:.0f} t (placed {r['tonnage'] + r['lost_t']:.0f} t)")
    if len(rows) > 1:
        a, b = rows[0], rows[-1]
        # the resolutions' difference: only between runs that differ in nothing else (tolerance, seed)
        if a["q0"] and b["q0"] and a["label"] != b["label"] and (a.get("tolerance"), a.get("seed")) == (
                b.get("tolerance"), b.get("seed")):
            same = bool(a["closed"]) == bool(b["closed"])
            tons = (f"tonnage {100 * (a['tonnage'] - b['tonnage']) / max(b['tonnage'], 1e-9):+.1f} %" if same else
                    "tonnage not comparable (the outcomes differ: "
                    + " / ".join("closed" if r["closed"] else "not closed" for r in (a, b)) + ")")
            print(f"  {a['label']} vs {b['label']}: discharge {100 * (a['q0'] - b['q0']) / b['q0']:+.1f} %, "
                  f"peak speed {100 * (a['vmax0'] - b['vmax0']) / b['vmax0']:+.1f} %, {tons}")
    print("\ntargets (2 cores):")
    for r in rows:
        if r["fine"] == 2.0:
            ok = "MET" if r["wall_total"] < TARGET_2M_WALL else "NOT MET"
            how = "closed" if r["closed"] else ("verdict: not closable" if r["verdict"] else "ended not closed")
            print(f"  whole run at 2 m cells ({r['label']}) < {TARGET_2M_WALL:.0f} s wall: {r['wall_total']:.0f} s "
                  f"(CPU {r['cpu']:.0f} s; {how} after {r['cycles']} cycles) — {ok}")
        proj = MEMBERS * r["cpu"] / CORES
        ok = "MET" if proj < NIGHT else "NOT MET"
        how = "closed" if r["closed"] else "not closed"
        print(f"  {MEMBERS}-member ensemble at {r['label']} overnight (< {NIGHT / 3600:.0f} h): projected "
              f"{MEMBERS} x {r['cpu']:.0f} CPU s / {CORES} cores = {proj / 3600:.1f} h — {ok} (projection from "
              f"one run, {how} after {r['cycles']} cycles; `breachflow ensemble "
              f"examples/ensembles/typical_feasibility.toml` measures it)")


def _outcome(r) -> str:
    return "closed" if r["closed"] else ("not closable" if r["verdict"] else "not closed")


def _span(vals, fmt="{:.0f}") -> str:
    vals = [v for v in vals if v == v]
    if not vals:
        return "-"
    if len(vals) == 1:
        return fmt.format(vals[0])
    return f"{fmt.format(_mean(vals))} ({fmt.format(min(vals))}-{fmt.format(max(vals))})"


def sweep_table(rows) -> None:
    """Per resolution and tolerance, over the seeds: outcomes, cycles, masses, tonnage, lost, CPU time."""
    print("\ntolerance x seed sweep (mean (min-max) over the seeds; each run one closure):")
    hdr = ("cells", "tolerance", "seeds", "outcomes", "cycles", "in place t", "lost", "open Q m3/s", "final Q m3/s",
           "CPU s", "solve CPU s/cycle")
    print("  " + " | ".join(hdr))
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["label"], r["tolerance"]), []).append(r)
    for (label, tol), g in groups.items():
        outs = ", ".join(f"{_outcome(r)} [{r['seed']}]" for r in g)
        print("  " + " | ".join((label, tol, str(len(g)), outs, _span([r["cycles"] for r in g], "{:.1f}"),
                                 _span([r["tonnage"] for r in g]), _span([r["lost"] for r in g], "{:.1f}"),
                                 _span([r["q0"] or float("nan") for r in g]),
                                 _span([r["q"][-1] if r["q"] else float("nan") for r in g], "{:.1f}"),
                                 _span([r["cpu"] for r in g]), _span([_mean(r["cpu_solve"]) for r in g], "{:.2f}"))))
    print("\nper run: breach discharge (m3/s) after each cycle, seepage after the last")
    for r in rows:
        qs = " ".join(f"{q:.0f}" for q in r["q"])
        print(f"  {r['label']} tol {r['tolerance']} seed {r['seed']}: {_outcome(r)}, Q {qs}; seepage "
              f"{(r['seepage'] or [float('nan')])[-1]:.0f}")


def dem_ratio(n_steps: int = 1500) -> None:
    """µs per DEM step of the default scenario's cycle 1: fluid forces term by term, fused per Python step,
    many steps per compiled call."""
    import numpy as np

    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun, dem_view
    from breachflow.cycle.main import default_scenario_text
    from breachflow.fluid.forces import FluidForces
    from breachflow.field.sampling import FieldSampler
    from breachflow.scenario.config import parse_scenario

    text = default_scenario_text()
    setup = closure_setup(parse_scenario(text))
    snap = setup.solver.solve(setup.domain)
    variants = {"term by term": (False, False), "fused, per step": (True, False), "compiled loop": (True, True)}
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(2):  # interleaved: load drifts on a shared machine
            for name, (fused, loop) in variants.items():
                run = ClosureRun(setup, Path(tmp) / f"r{rep}{len(out)}{fused}{loop}", text, overwrite=True)
                d = setup.dem
                orig = run.dem.fluid
                run.dem.fluid = lambda s, c=fused: FluidForces(dem_view(s), drag_law=d.drag_law, sampling=d.sampling,
                                                            xi=d.xi, velocity_profile=d.velocity_profile,
                                                            roughness=d.roughness,
                                                            manning=float(np.median(setup.domain.manning)),
                                                            outside="air", compiled=c)
                sim = run.dem.make(snap)
                sim.compiled = loop
                sampler = FieldSampler(snap, method="bilinear")

                def surface_at(x, y):
                    smp = sampler.sample(np.asarray(x, float), np.asarray(y, float))
                    return np.where(smp.inside, np.maximum(smp.surface, smp.bed), np.nan)

                rel = setup.placement.release(1, setup.seed, surface_at)
                run.dem.add(sim, rel.pos, rel.radius, rel.density)
                sim.step(10)
                c0 = time.process_time()
                sim.step(n_steps)
                cpu = time.process_time() - c0
                out.setdefault(name, []).append((cpu, sim.state.pos.copy(), sim.n_awake))
                run.dem.fluid = orig
    us = {name: min(c for c, _, _ in v) / n_steps * 1e6 for name, v in out.items()}
    spread = {name: max(c for c, _, _ in v) / n_steps * 1e6 for name, v in out.items()}
    ref = out["term by term"][0][1]
    print(f"\nDEM of the default run's cycle 1 ({n_steps} steps, 5 masses; CPU µs per step, best (worst) of 2 "
          f"interleaved):")
    for name in variants:
        dx = float(np.abs(out[name][0][1] - ref).max())
        same = np.array_equal(out[name][0][1], out["fused, per step"][0][1])
        print(f"  {name:16s} {us[name]:7.1f} ({spread[name]:.1f}) µs/step, {us['term by term'] / us[name]:5.1f}x "
              f"the term-by-term path; largest position difference to it {dx:.2e} m; "
              f"bit-identical to fused per step: {same}")


def main(argv) -> int:
    if argv and argv[0] == "--child":
        child(*argv[1:4])
        return 0
    ap = argparse.ArgumentParser(prog="bench closure")
    ap.add_argument("--resolutions", default="4,2")
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "typical_breach.toml"))
    ap.add_argument("--no-dem", action="store_true")
    ap.add_argument("--threads", type=int, default=None,
                    help="[hydro] threads of the re-solves (numba threads; default the scenario's)")
    ap.add_argument("--tolerances", default="",
                    help="comma-separated [hydro] tolerance values in 1/s (default: the scenario's)")
    ap.add_argument("--seeds", default="", help="comma-separated [closure] seed values (default: the scenario's)")
    ap.add_argument("--json", default=None, help="write every run's figures to this JSON file")
    a = ap.parse_args(argv)
    tols = [t.strip() for t in a.tolerances.split(",") if t.strip()] or [None]
    seeds = [int(x) for x in a.seeds.split(",") if x.strip()] or [None]
    for t in tols:
        if t is not None and not (float(t) > 0.0):
            raise SystemExit(f"--tolerances: {t!r} is not a positive number (1/s)")
    if not a.no_dem:
        dem_ratio()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-closure-") as tmp:
        for item in [r for r in a.resolutions.split(",") if r.strip()]:
            for tol in tols:
                for seed in seeds:
                    rows.append(one_resolution(Path(a.scenario), item, Path(tmp), a.threads, tol, seed))
                    report(rows[-1:])
                    if a.json:  # after every run: a long sweep keeps what it measured
                        Path(a.json).write_text(json.dumps(rows, indent=1, default=str))
    if len(rows) > 1:
        print("\n=== all runs ===")
        report(rows)
    if len(tols) > 1 or len(seeds) > 1:
        sweep_table(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
