"""Is the typical breach's flow steady at all? Breach discharge and probe speeds against simulated time (issue 16).

    python3 tasks.py bench steady_trace [--resolution 4] [--t-end 3600] [--every 1] [--pile] [--out DIR]

The report's typical breach (``[site] preset = "typical_breach"``) at ``--resolution`` is marched from
its cold start (flood side at the source level, polder dry) for ``--t-end`` s of simulated time, with the
closure run's solver options; every ``--every`` s it records

* the breach discharge Q (:func:`breachflow.cycle.criteria.section_discharge`, the median over the
  opening's rows, m³/s) and the discharge across the levee row alone,
* the speed at probes: breach centre on the levee line; the jet 0.5 B and 2 B downstream of it; behind
  each levee head (breach end ± 0.25 B, 0.5 B downstream); the polder 4 B downstream,
* the water volume of the domain and the outflow across the polder's north edge.

With ``--pile`` the region-bench pile (an asymmetric mound against the west breach wall, 40 % of B long,
raised to 60 % of the flood depth) is in place. After the first ``--skip`` s, each record's mean, standard
deviation, its dominant period (the peak of the periodogram of the record with its mean and linear trend
removed) and the linear trend over the record (drift, per 1000 s) are printed; a plot is written to
``--out`` (default ``benchmarks/results/steady_trace``) with the records (``trace_<res>m.npz``).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

SCENARIO = """
[scenario]
name = "steady trace"
[site]
preset = "typical_breach"
[hydro]
resolution = "{res:g} m"
"""


def spectrum_period(t, y):
    """Dominant period (s) and its peak-to-peak amplitude of a uniformly sampled record *y(t)*, detrended."""
    dt = float(t[1] - t[0])
    r = y - np.polyval(np.polyfit(t, y, 1), t)
    f = np.fft.rfftfreq(r.size, dt)
    p = np.abs(np.fft.rfft(r * np.hanning(r.size))) ** 2
    k = int(np.argmax(p[1:])) + 1
    return 1.0 / f[k], float(np.percentile(r, 98) - np.percentile(r, 2))


def main(argv=None) -> int:
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import row_discharge, section_discharge
    from breachflow.swe import SWESimulation
    from breachflow.scenario.config import parse_scenario

    ap = argparse.ArgumentParser(prog="bench steady_trace")
    ap.add_argument("--resolution", type=float, default=4.0)
    ap.add_argument("--t-end", type=float, default=3600.0)
    ap.add_argument("--every", type=float, default=1.0)
    ap.add_argument("--skip", type=float, default=600.0, help="statistics after this simulated time (s)")
    ap.add_argument("--pile", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results" / "steady_trace"))
    a = ap.parse_args(argv)
    setup = closure_setup(parse_scenario(SCENARIO.format(res=a.resolution)))
    dom = setup.domain
    warm = setup.solver.warm
    x0, x1 = setup.breach_x
    B = x1 - x0
    xc, yl = 0.5 * (x0 + x1), setup.levee_y
    X, Y = np.meshgrid(dom.x, dom.y)
    if a.pile:
        low = float(dom.bed[np.abs(Y - yl) < dom.dy].min())
        mask = (X > x0) & (X < x0 + 0.4 * B) & (np.abs(Y - yl) < 0.12 * B)
        dom = dom.with_raised_bed(mask, low + 0.6 * (setup.flood_level - low))
    probes = {"breach centre": (xc, yl), "jet 0.5B": (xc, yl + 0.5 * B), "jet 2B": (xc, yl + 2 * B),
              "west head": (x0 + 0.25 * B, yl + 0.5 * B), "east head": (x1 - 0.25 * B, yl + 0.5 * B),
              "polder 4B": (xc, yl + 4 * B)}
    idx = {k: (int(np.argmin(np.abs(dom.y - py))), int(np.argmin(np.abs(dom.x - px)))) for k, (px, py) in probes.items()}
    sim = SWESimulation(dom, warm.options)
    print(f"typical breach at {a.resolution:g} m ({dom.shape[1]} x {dom.shape[0]} cells){' with the pile' if a.pile else ''}; "
          f"breach x {x0:.1f}..{x1:.1f} m, levee y {yl:g} m; polder north edge y {dom.y[-1]:.0f} m", flush=True)
    n = int(round(a.t_end / a.every))
    rec = {k: np.zeros(n) for k in ["t", "Q", "Q_levee_row", "volume", "north_outflow", *probes]}
    c0 = time.process_time()
    for k in range(n):
        sim.advance_to((k + 1) * a.every)
        ds = sim.snapshot(derived=False)
        u, v = sim.velocity()
        sp = np.hypot(u, v)
        rec["t"][k] = sim.t
        rec["Q"][k] = section_discharge(ds, setup.breach_x, yl)
        rec["Q_levee_row"][k] = row_discharge(ds, setup.breach_x, yl)
        rec["volume"][k] = sim.volume()
        rec["north_outflow"][k] = float(sim.discharge[1][-1].sum() * sim.dx)
        for name, (j, i) in idx.items():
            rec[name][k] = sp[j, i]
        if (k + 1) % max(1, n // 20) == 0:
            print(f"  t {sim.t:6.0f} s: Q {rec['Q'][k]:8.1f} m3/s, jet 0.5B {rec['jet 0.5B'][k]:.2f} m/s, "
                  f"volume {rec['volume'][k]:.4g} m3, {time.process_time() - c0:.0f} CPU s", flush=True)
    cpu = time.process_time() - c0
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{a.resolution:g}m{'_pile' if a.pile else ''}"
    np.savez(out / f"trace_{tag}.npz", **{k.replace(" ", "_").replace(".", "p"): v for k, v in rec.items()})
    late = rec["t"] > a.skip
    t = rec["t"][late]
    print(f"\n{n} records in {cpu:.0f} CPU s; statistics over t > {a.skip:g} s ({t.size} records)")
    print(f"  {'record':>16} | {'mean':>10} | {'sd':>9} | {'sd/mean %':>9} | {'period s':>8} | {'p-p (2-98%)':>11} | "
          f"{'trend /1000 s':>13}")
    for name in ["Q", "Q_levee_row", *probes, "volume", "north_outflow"]:
        y = rec[name][late]
        period, pp = spectrum_period(t, y)
        trend = np.polyfit(t, y, 1)[0] * 1000.0
        print(f"  {name:>16} | {y.mean():10.4g} | {y.std():9.3g} | {100 * y.std() / abs(y.mean()):9.2f} | "
              f"{period:8.1f} | {pp:11.3g} | {trend:+13.3g}")
    # the running mean of Q from two halves: does it drift?
    q = rec["Q"][late]
    h = q.size // 2
    print(f"  Q mean of the first / second half of the record: {q[:h].mean():.2f} / {q[h:].mean():.2f} m3/s")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot")
        return 0
    fig, ax = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    ax[0].plot(rec["t"], rec["Q"], lw=0.8, label="Q (median over the opening's rows)")
    ax[0].plot(rec["t"], rec["Q_levee_row"], lw=0.6, alpha=0.7, label="Q (levee row)")
    ax[0].set_ylabel("breach discharge m³/s")
    ax[0].legend(fontsize=8)
    for name in probes:
        ax[1].plot(rec["t"], rec[name], lw=0.7, label=name)
    ax[1].set_ylabel("speed m/s")
    ax[1].legend(fontsize=7, ncol=3)
    ax[2].plot(rec["t"], rec["north_outflow"], lw=0.8, label="outflow across the polder's north edge")
    ax[2].plot(rec["t"], rec["Q"], lw=0.6, alpha=0.6, label="breach Q")
    ax[2].set_ylabel("m³/s")
    ax[2].set_xlabel("simulated time s")
    ax[2].legend(fontsize=8)
    fig.suptitle(f"typical breach at {a.resolution:g} m{' with pile' if a.pile else ''}: cold start, {cpu:.0f} CPU s")
    fig.tight_layout()
    fig.savefig(out / f"trace_{tag}.png", dpi=110)
    print(f"plot: {out / f'trace_{tag}.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
