"""Work–precision of the region re-solve on a closure cycle's pile, against a settled reference (issue 16).

    python3 tasks.py bench region_wp [--resolution 4] [--tolerances 2e-3,5e-4,2e-4,5e-5] [--reference 2e-5]
                                     [--reference-t-max 2400] [--t-max 600] [--scenario examples/typical_breach.toml]
                                     [--no-full] [--out benchmarks/results/region_wp]

The pile is a real one: the scenario (default the shipped typical breach, ``examples/typical_breach.toml``,
at ``--resolution``) runs its first closure cycle as ``breachflow run`` does (cold open-breach solve, DEM
of the first 20 masses, remap), and that cycle's warm re-solve — its domain with the remapped pile and
its warm start, the open breach's steady state — is the problem every solve below re-solves:

* reference: the full domain at ``--reference`` (1/s), at least ``--reference-min-time`` s (the
  averaged criterion alone stopped it after 313 s at 4 m, inside the slow transient), with the averaged criterion
  (``run_to_steady(average=True)``, :mod:`breachflow.swe.steady_mean`: batch means of the breach
  discharge, the first half of the record left out as the transient), t_max ``--reference-t-max``. Its
  breach discharge is given with the batch-means error (standard error and half-drift,
  ``BatchMeans.stats``) and the linear drift of Q over the averaging region (per 1000 s); the largest
  speed near the pile with the standard error of that speed over the averaging region's checks
  (batch means over the checks, the same estimator);
* for each tolerance of ``--tolerances``: the full-domain re-solve (``resolve = "full"``, skipped with
  ``--no-full``) and the region re-solve (``resolve = "region"``, frozen far field, default margin 2 B
  and edge level 0.03 m), t_max ``--t-max``; at the tolerances of ``--frozen`` also the region that
  never grows (``region-nogrow``, edge level 1 km): the error of the frozen far field itself; at the
  tolerances of ``--average`` the full-domain re-solve with the averaged criterion (``full-avg``,
  ``[hydro] steady_average = true``).

"Near the pile": the open cells within B (the breach length) of the breach centre. Printed per solve:
breach discharge Q and its difference to the reference (%, and in units of the reference's error σ_Q),
the largest speed near the pile and its difference (m/s, and in σ_v), the mean |Δ speed| there, the
simulated time, this process's CPU time and the region (cells, share of the domain, growths). The
effect of the pile change itself (the warm start against the reference) is printed for scale. A plot of
the errors against CPU time and of the reference's record is written to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]  # benchmarks/


def _se_batch(values) -> float:
    """Batch-means standard error (and half-drift) of a record, the reference's own estimator."""
    from breachflow.swe.steady_mean import BatchMeans

    v = np.asarray(values, float)
    if v.size < 8:
        return float("nan")
    acc = BatchMeans(max(1, v.size // 16))
    for k, x in enumerate(v):
        acc.add(float(k), float(x))
    return acc.stats()[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench region_wp", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default=str(HERE.parent / "examples" / "typical_breach.toml"))
    ap.add_argument("--resolution", type=float, default=4.0)
    ap.add_argument("--tolerances", default="2e-3,5e-4,2e-4,5e-5")
    ap.add_argument("--reference", type=float, default=2e-5)
    ap.add_argument("--reference-t-max", type=float, default=3000.0)
    ap.add_argument("--reference-min-time", type=float, default=1500.0,
                    help="simulated time (s) the reference runs at least before its criterion may stop it")
    ap.add_argument("--frozen", default="2e-4,5e-5", help="tolerances of the region re-solve that never grows "
                    "(edge_level 1 km): the frozen far field's own error")
    ap.add_argument("--t-max", type=float, default=600.0, help="t_max (s) of the re-solves at --tolerances")
    ap.add_argument("--no-full", action="store_true", help="region re-solves only (no full-domain ones)")
    ap.add_argument("--average", default="2e-3,2e-4", help="tolerances of a full-domain re-solve with the "
                    "averaged criterion too (full-avg: [hydro] steady_average = true)")
    ap.add_argument("--out", default=str(HERE / "results" / "region_wp"))
    a = ap.parse_args(argv)
    sys.path.insert(0, str(HERE / "dev"))
    from bench_steady import record

    from breachflow.cycle.criteria import section_discharge
    from breachflow.swe import SWESimulation
    from breachflow.hydro.resolve_region import RegionResolver
    from breachflow.scenario.toml import scenario_with

    text = scenario_with(Path(a.scenario).read_text(), {"hydro.resolution": f"{a.resolution:g} m",
                                                        "criteria.max_cycles": 1})
    c0 = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        setup, rec = record(text, tmp + "/run")
    if not rec.calls:
        print("the scenario made no warm re-solve in its first cycle")
        return 1
    call = rec.calls[0]
    dom, obst, init = call["domain"], call["obstacles"], call["initial"]
    warm = rec.solver.warm
    sec = warm.section
    x0, x1 = setup.breach_x
    B = x1 - x0
    X, Y = np.meshgrid(dom.x, dom.y)
    near = (np.hypot(X - 0.5 * (x0 + x1), Y - setup.levee_y) <= B) & ~dom.obstacle
    pile = getattr(dom, "porous", None)
    n_pile = int((pile.height > 0).sum()) if pile is not None else 0
    print(f"{Path(a.scenario).name} at {a.resolution:g} m ({dom.shape[1]} x {dom.shape[0]} cells): first cycle "
          f"recorded in {time.process_time() - c0:.0f} CPU s; pile on {n_pile} cells; warm start Q "
          f"{section_discharge(init, setup.breach_x, setup.levee_y):.1f} m3/s", flush=True)

    def speeds(ds):
        return np.hypot(ds.u.values, ds.v.values)

    def result(ds, cpu, sim, info):
        sp = speeds(ds)
        return dict(q=section_discharge(ds, setup.breach_x, setup.levee_y), vmax=float(sp[near].max()), sp=sp,
                    h=ds.depth.values, cpu=cpu, t=sim.t,
                    steps=sim.steps, converged=sim.history.converged, info=info)

    # the reference: full domain, tight tolerance, averaged criterion
    trace = []

    def progress(s, hist):
        u, v = s.velocity()
        trace.append((s.t, hist.section_discharge[-1], float(np.hypot(u, v)[near].max()),
                      hist.section_mean[-1], hist.section_se[-1]))

    c = time.process_time()
    sim = SWESimulation(dom, warm.options, obstacles=obst, initial=init)
    t_start = sim.t
    hist = sim.run_to_steady(a.reference, a.reference_t_max, warm.check_interval, min_time=a.reference_min_time,
                             region=warm.region, section=sec, average=True, progress=progress)
    ref = result(sim.snapshot(derived=False), time.process_time() - c, sim, {"mode": "full"})
    tr = np.array(trace)
    if hist.averaged:
        w0, w1 = hist.average_interval
    else:  # settled on the rate test or stopped at t_max: the second half of the record
        w0, w1 = t_start + 0.5 * (sim.t - t_start), sim.t
    inw = (tr[:, 0] >= w0) & (tr[:, 0] <= w1)
    sig_q = float(hist.section_se[-1]) if np.isfinite(hist.section_se[-1]) else _se_batch(tr[inw, 1])
    sig_v = _se_batch(tr[inw, 2])
    drift = float(np.polyfit(tr[inw, 0], tr[inw, 1], 1)[0]) * 1000.0 if inw.sum() > 2 else float("nan")
    drift_all = float(np.polyfit(tr[tr[:, 0] > t_start + 0.5 * (sim.t - t_start), 0],
                                 tr[tr[:, 0] > t_start + 0.5 * (sim.t - t_start), 1], 1)[0]) * 1000.0
    print(f"reference: full domain at {a.reference:.0e} 1/s, averaged criterion: "
          f"{'converged on the mean' if hist.averaged else ('settled' if hist.converged else 'NOT converged')} after "
          f"{sim.t - t_start:.0f} s simulated, {ref['cpu']:.0f} CPU s; averaging region {w0 - t_start:.0f}..{w1 - t_start:.0f} s "
          f"({inw.sum()} checks); Q {ref['q']:.2f} m3/s (running mean {hist.section_mean[-1]:.2f}), "
          f"sigma_Q {sig_q:.3f} m3/s ({100 * sig_q / ref['q']:.3f} %), drift of Q over the region {drift:+.2f} m3/s "
          f"per 1000 s ({100 * drift / ref['q']:+.3f} %; over the second half of the record {drift_all:+.2f}); "
          f"vmax near the pile {ref['vmax']:.3f} m/s, sigma_v {sig_v:.4f} m/s", flush=True)
    before = dict(q=section_discharge(init, setup.breach_x, setup.levee_y), vmax=float(speeds(init)[near].max()))

    rows = []
    for tol in [float(t) for t in a.tolerances.split(",") if t]:
        import copy

        full = copy.copy(warm)
        full.tolerance, full.t_max = tol, a.t_max
        solvers = [] if a.no_full else [("full", full)]
        solvers.append(("region", RegionResolver(full)))
        if tol in [float(t) for t in a.average.split(",") if t] and not a.no_full:
            avg = copy.copy(full)
            avg.average = True
            solvers.append(("full-avg", avg))
        if tol in [float(t) for t in a.frozen.split(",") if t]:
            solvers.append(("region-nogrow", RegionResolver(full, edge_level=1e3)))
        for name, solver in solvers:
            c = time.process_time()
            ds = solver.solve(dom, obstacles=obst, initial=init)
            cpu = time.process_time() - c
            info = getattr(solver, "last_info", None) or {"mode": "full", "cells": int(np.prod(dom.shape))}
            r = result(ds, cpu, solver.last, info)
            rows.append((name, tol, r))
            print(f"  {name} at {tol:.0e}: Q {r['q']:.2f} m3/s, vmax {r['vmax']:.3f} m/s, {cpu:.1f} CPU s, "
                  f"{ {k: info[k] for k in ('mode', 'why', 'grown', 'fraction', 'edge_change') if k in info} }",
                  flush=True)

    ncell = int(np.prod(dom.shape))
    print(f"\nfirst cycle's pile ({n_pile} porous cells), re-solved warm from the open breach; near the pile: within "
          f"B = {B:.1f} m of the breach centre. Reference Q {ref['q']:.2f} ± {sig_q:.2f} m3/s, vmax {ref['vmax']:.3f} ± "
          f"{sig_v:.3f} m/s; effect of the pile change (warm start - reference): dQ {before['q'] - ref['q']:+.1f} m3/s "
          f"({100 * (before['q'] - ref['q']) / ref['q']:+.2f} %), dvmax {before['vmax'] - ref['vmax']:+.3f} m/s")
    hdr = ("re-solve", "tol 1/s", "Q m3/s", "dQ %", "dQ/sQ", "vmax m/s", "dvmax", "dv/sv", "mean|dv|", "sim s",
           "CPU s", "cells %", "grown")
    print("  " + " | ".join(f"{h:>8}" for h in hdr))
    out_rows = []
    for name, tol, r in [("reference", a.reference, ref)] + rows:
        wet = near & (r["h"] > 0.01) & (ref["h"] > 0.01)
        dv = np.abs(r["sp"] - ref["sp"])[wet]
        info = r["info"]
        frac = 100.0 * info.get("cells", ncell) / ncell
        row = dict(name=name, tol=tol, q=r["q"], dq_pct=100 * (r["q"] - ref["q"]) / ref["q"],
                   dq_sigma=(r["q"] - ref["q"]) / sig_q, vmax=r["vmax"], dvmax=r["vmax"] - ref["vmax"],
                   dv_sigma=(r["vmax"] - ref["vmax"]) / sig_v, mean_dv=float(dv.mean()), t=r["t"],
                   converged=bool(r["converged"]), cpu=r["cpu"], cells_pct=frac,
                   grown=info.get("grown", 0) if info.get("mode") == "region" else (
                       "full" if name.startswith("full") or name == "reference" else f"full@{info.get('grown', 0)}"))
        out_rows.append(row)
        print("  " + " | ".join(f"{v:>8}" for v in (
            name, f"{tol:.0e}", f"{r['q']:.2f}", f"{row['dq_pct']:+.3f}", f"{row['dq_sigma']:+.1f}",
            f"{r['vmax']:.3f}", f"{row['dvmax']:+.3f}", f"{row['dv_sigma']:+.1f}", f"{row['mean_dv']:.4f}",
            f"{r['t'] - (t_start if name == 'reference' else 0.0):.0f}{'' if r['converged'] else '*'}",
            f"{r['cpu']:.1f}", f"{frac:.1f}", row["grown"])))
    print("  (* not converged within t_max; sim s of the reference counted from its warm start; grown full@N: the "
          "region grew N times, then the full domain was re-solved)")
    for tol in sorted({t for _, t, _ in rows}):
        f = [r for n, t, r in rows if n == "full" and t == tol]
        w = [r for n, t, r in rows if n == "region" and t == tol]
        if f and w:
            print(f"  tol {tol:.0e}: CPU region / full = {w[0]['cpu'] / max(f[0]['cpu'], 1e-9):.2f}; "
                  f"Q region - full = {w[0]['q'] - f[0]['q']:+.2f} m3/s ({100 * (w[0]['q'] - f[0]['q']) / f[0]['q']:+.3f} %)")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{a.resolution:g}m"
    (out / f"region_wp_{tag}.json").write_text(json.dumps(dict(
        reference=dict(tol=a.reference, q=ref["q"], sigma_q=sig_q, vmax=ref["vmax"], sigma_v=sig_v,
                       drift_per_1000s=drift, averaged=bool(hist.averaged), region=[w0 - t_start, w1 - t_start],
                       cpu=ref["cpu"]), before=before, rows=out_rows), indent=1))
    np.save(out / f"reference_trace_{tag}.npy", tr)
    _plot(out / f"region_wp_{tag}.png", out_rows[1:], ref, sig_q, sig_v, before, tr, t_start, (w0, w1),
          f"{Path(a.scenario).stem} at {a.resolution:g} m, first cycle's pile")
    return 0


def _plot(path, rows, ref, sig_q, sig_v, before, tr, t_start, region, title):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot")
        return
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for name, mk in (("full", "o-"), ("region", "s-"), ("region-nogrow", "^-"), ("full-avg", "v-")):
        rr = [r for r in rows if r["name"] == name]
        if not rr:
            continue
        cpu = [r["cpu"] for r in rr]
        ax[0].loglog(cpu, [max(abs(r["dq_pct"]), 1e-4) for r in rr], mk, label=name)
        ax[1].loglog(cpu, [max(abs(r["dvmax"]), 1e-5) for r in rr], mk, label=name)
        for r, x in zip(rr, cpu):
            ax[0].annotate(f"{r['tol']:.0e}", (x, max(abs(r["dq_pct"]), 1e-4)), fontsize=7)
    ax[0].axhline(100 * sig_q / ref["q"], color="k", ls="--", lw=0.8, label="reference σ_Q")
    ax[0].axhline(100 * abs(before["q"] - ref["q"]) / ref["q"], color="r", ls=":", lw=0.8, label="pile effect |ΔQ|")
    ax[1].axhline(sig_v, color="k", ls="--", lw=0.8, label="reference σ_v")
    ax[1].axhline(abs(before["vmax"] - ref["vmax"]), color="r", ls=":", lw=0.8, label="pile effect |Δv_max|")
    ax[0].set(xlabel="CPU s", ylabel="|ΔQ| against the reference, %", title="breach discharge")
    ax[1].set(xlabel="CPU s", ylabel="|Δ v_max| near the pile, m/s", title="max speed near the pile")
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    t = tr[:, 0] - t_start
    ax[2].plot(t, tr[:, 1], lw=0.8, label="Q per check")
    ax[2].plot(t, tr[:, 3], lw=1.0, label="running mean")
    ax[2].axvspan(region[0] - t_start, region[1] - t_start, color="0.9", label="averaging region")
    ax[2].axhline(ref["q"], color="k", ls="--", lw=0.8)
    ax[2].set(xlabel="simulated s since the warm start", ylabel="breach discharge m³/s", title="reference record")
    ax[2].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"plot: {path}")


if __name__ == "__main__":
    raise SystemExit(main())
