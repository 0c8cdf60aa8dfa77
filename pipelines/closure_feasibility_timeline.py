#!/usr/bin/env python3
"""Closure feasibility in time: start time × delivery method (docs/closure-timeline.md).

    python pipelines/closure_feasibility_timeline.py OUTPUT_DIR
    python pipelines/closure_feasibility_timeline.py OUTPUT_DIR --starts 0 2 4 6 --methods split_barge end_dumping
    python pipelines/closure_feasibility_timeline.py OUTPUT_DIR --scenario examples/typical_breach.toml \
        --resolution 8 --starts 24 36 48 --max-cycles 30

"With this method, starting then, do we close it, when, with how much?" Every member is one closure run in
time (``[closure] method`` and ``start``): the breach opens at the flood's crest, the polder fills through
it until the start, then the masses are delivered at the method's capacity while the flood falls and the
polder keeps filling; each cycle's flow is solved at the flood and polder levels of its operation time.
The member's closure plan (``closure_plan.json``) gives the tonnage, the finish and whether it fits in
the window of the simulated polder (breach balance or inundation limit). The window of the breach left open
is the breach's, the same for every member: its weir is calibrated on the open breach at its full size, not at
the member's start.

The base scenario is the embedded demo breach (3 m levee, water at the crest, 12 m breach) on a coarse
grid (2 m, first order) with a hurricane flood (fall 0.3 m/h), a 100 ha polder that may be inundated
1.5 m deep, and 4.7–8.1 t rock (1.5–1.8 m spheres): by split barges along the levee line, or end-dumped
from the breach heads. The default grid is 2 methods × 3 start times (a few CPU minutes); the capacities
are the methods' defaults (``--capacity`` scales them all, e.g. 0.1 for a breach this small).

Writes ``OUTPUT_DIR/members/<method>_<start>h/`` (run directories with their plans),
``OUTPUT_DIR/feasibility.json`` (one row per member) and ``OUTPUT_DIR/closure_feasibility_timeline.png``
(tonnage and finish time against start time per method, the window's end marked), and prints the
earliest start at which each method closes the breach inside its window. Rerunning reuses finished members.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from closure_feasibility import QUICK_SITE  # the base site, shared with the feasibility map (this folder)

DEFAULT_STARTS = [0.0, 2.0, 4.0]
DEFAULT_METHODS = ["split_barge", "end_dumping"]

BASE = """
[scenario]
name = "closure in time: {method}, start {start:g} h"

""" + QUICK_SITE + """
[placement]
diameter = ["1.5 m", "1.8 m"]
batch = 6
positions = "{positions}"
release_height = "1 m"

[criteria]
mode = "any"
max_cycles = {max_cycles}
max_speed = "1 m/s"
blocked_fraction = 0.5

[closure]
remap = "raised_bed"
method = "{method}"
start = "{start:g} h"
{capacity}
"""

#: the placement strategy each method works by default
POSITIONS = {"end_dumping": "horizontal", "split_barge": "line", "barge_crane": "line", "cableway": "line",
             "helicopter": "line"}


def member_text(method: str, start_h: float, *, capacity_factor: float = 1.0, max_cycles: int = 8,
                scenario: str | None = None, resolution: float | None = None) -> str:
    """The member's scenario: the demo breach (``BASE``), or the TOML text *scenario* (e.g. the typical breach)
    with ``[closure] method`` and ``start`` set, the method's placement strategy where the scenario's cannot be
    worked by it, ``max_cycles`` and, given, ``[hydro] resolution`` (m)."""
    from breachflow.cycle.delivery import HOUR, TONNE, delivery_method

    cap = ""
    if capacity_factor != 1.0:
        cap = f'capacity = "{delivery_method(method).capacity * capacity_factor * HOUR / TONNE:g} t/hr"'
    if scenario is not None:
        import tomllib

        from breachflow.scenario.toml import scenario_with

        changes = {"closure.method": method, "closure.start": f"{start_h:g} h", "criteria.max_cycles": int(max_cycles)}
        own = tomllib.loads(scenario).get("placement", {}).get("positions", "line")
        if own not in delivery_method(method).positions:
            changes["placement.positions"] = POSITIONS.get(method, "line")
        if cap:
            changes["closure.capacity"] = cap.split('"')[1]
        if resolution is not None:
            changes["hydro.resolution"] = f"{resolution:g} m"
        return scenario_with(scenario, changes)
    return BASE.format(method=method, start=start_h, positions=POSITIONS.get(method, "line"), capacity=cap,
                       max_cycles=int(max_cycles))


def run_member(out: Path, method: str, start_h: float, capacity_factor: float, max_cycles: int,
               scenario: str | None = None, resolution: float | None = None) -> dict:
    """Run (or reuse) one member; returns its row."""
    run_dir = out / "members" / f"{method}_{start_h:g}h"
    plan_path = run_dir / "closure_plan.json"
    if not plan_path.exists():
        from breachflow.cycle.main import run_closure

        run_dir.parent.mkdir(parents=True, exist_ok=True)
        scen = out / "members" / f"{method}_{start_h:g}h.toml"
        scen.write_text(member_text(method, start_h, capacity_factor=capacity_factor, max_cycles=max_cycles,
                                    scenario=scenario, resolution=resolution))
        run_closure(scen, run_dir, overwrite=True, plots=False)
    return member_row(method, start_h, json.loads(plan_path.read_text()))


def member_row(method: str, start_h: float, plan: dict) -> dict:
    """One member's row from its closure plan. ``window_h`` is the window of the breach left open (the same
    for every member: the chart's deadline), ``window_weir`` the weir coefficient it was calibrated to (on the
    open breach at its full size); ``run_balance_h`` is when the polder met the flood during this member's own
    closure, which makes the member miss its window (``fits``) when it comes first."""
    w = plan["window"]
    hours = lambda s: None if s is None else s / 3600.0
    cal = w.get("calibration") or {}
    return {"method": method, "start_h": start_h, "closed": plan["closed"], "fits": w["fits"],
            "placed_t": plan["placed_t"], "finish_h": plan["finish_s"] / 3600.0,
            "duration_h": plan["duration_s"] / 3600.0, "window_h": hours(w["open_breach_window_s"]),
            "window_weir": cal.get("weir_coefficient"), "window_calibrated_h": hours(cal.get("time_s")),
            "run_balance_h": hours(w["balance_time_s"]),
            "report_window_h": hours(w["report_closure_window_s"]),
            "leakage_m3_s": plan["leakage_end"]["breach_discharge_m3_s"], "verdict": plan["verdict"]}


def earliest(rows, method):
    """The earliest start (h) at which *method* closes the breach inside its window (None: none does)."""
    ok = sorted(r["start_h"] for r in rows if r["method"] == method and r["fits"])
    return ok[0] if ok else None


def figure(rows, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for method in sorted({r["method"] for r in rows}):
        rs = sorted((r for r in rows if r["method"] == method), key=lambda r: r["start_h"])
        s = [r["start_h"] for r in rs]
        line, = ax[0].plot(s, [r["placed_t"] for r in rs], "o-", label=method)
        ax[1].plot(s, [r["finish_h"] for r in rs], "o-", color=line.get_color(), label=method)
        for r in rs:  # open symbols: not closed inside the window
            if not r["fits"]:
                ax[0].plot(r["start_h"], r["placed_t"], "o", mfc="white", color=line.get_color())
                ax[1].plot(r["start_h"], r["finish_h"], "o", mfc="white", color=line.get_color())
    windows = sorted({r["window_h"] for r in rows if r["window_h"] is not None})
    for k, w in enumerate(windows):  # the breach left open: balance or inundation limit, one for the breach
        ax[1].axhline(w, color="red", lw=0.8, ls="--", label="end of the window (breach left open)" if k == 0 else None)
    report = [r["report_window_h"] for r in rows if r.get("report_window_h") is not None]
    if report:
        ax[1].axhline(report[0], color="grey", lw=0.8, ls=":", label="report's linear closure window")
    ax[0].set_xlabel("start of the closure after the breach (h)")
    ax[0].set_ylabel("placed (t)")
    ax[1].set_xlabel("start of the closure after the breach (h)")
    ax[1].set_ylabel("finish after the breach (h)")
    ax[1].legend(fontsize=8, loc="lower right")
    ax[0].set_title("tonnage (open: not closed inside the window)", fontsize=9)
    ax[1].set_title("finish time", fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path)
    p.add_argument("--starts", type=float, nargs="+", default=DEFAULT_STARTS, help="start times after the breach (h)")
    p.add_argument("--methods", nargs="+", default=DEFAULT_METHODS)
    p.add_argument("--capacity", type=float, default=1.0, help="factor on every method's capacity")
    p.add_argument("--max-cycles", type=int, default=8)
    p.add_argument("--scenario", type=Path, default=None,
                   help="a scenario file with [polder] (e.g. examples/typical_breach.toml) instead of the demo breach")
    p.add_argument("--resolution", type=float, default=None, help="[hydro] resolution of the members (m)")
    a = p.parse_args(argv)
    text = None if a.scenario is None else a.scenario.read_text(encoding="utf-8")
    a.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = []
    for method in a.methods:
        for start in a.starts:
            row = run_member(a.out, method, start, a.capacity, a.max_cycles, text, a.resolution)
            rows.append(row)
            print(f"{method:12s} start {start:5.1f} h: {'closed' if row['closed'] else 'not closed':10s} "
                  f"{row['placed_t']:8.1f} t, finish {row['finish_h']:6.2f} h, window "
                  f"{'-' if row['window_h'] is None else format(row['window_h'], '.2f')} h, "
                  f"{'fits' if row['fits'] else 'does not fit'}", flush=True)
    windows = sorted({round(r["window_h"], 9) for r in rows if r["window_h"] is not None})
    if len(windows) > 1:  # members of an older version, calibrated at their own starts
        print(f"the members' windows differ ({', '.join(f'{w:.1f}' for w in windows)} h): rerun them into a new "
              f"directory for the window of the breach")
    elif windows:
        print(f"window of the breach left open: {windows[0]:.2f} h (weir {rows[0]['window_weir']} m^0.5/s, "
              f"calibrated {rows[0]['window_calibrated_h']} h after the breach)")
    (a.out / "feasibility.json").write_text(json.dumps(rows, indent=1))
    print(f"wrote {figure(rows, a.out / 'closure_feasibility_timeline.png')}")
    for method in a.methods:
        e = earliest(rows, method)
        print(f"{method}: " + ("no start tried closes the breach inside its window" if e is None else
                               f"the earliest start that closes the breach inside its window is {e:g} h"))
    print(f"{len(rows)} members in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
