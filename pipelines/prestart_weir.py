"""The weir before the start of a closure against the embedded solver's open breach (docs/closure-timeline.md).

``python pipelines/prestart_weir.py [SCENARIO] [--resolution "1 m"]`` (default: the CI demo scene of the test
suite, ``tests/data/ci_closure.toml``, with ``[closure] method = "split_barge"``):

1. submergence: the open breach solved cold with the polder dry and with tailwaters of 0.50, 0.67, 0.76, 0.85
   and 0.92 of the head above the breach bottom; prints the solver's breach discharge, the report's weir
   (Fread's form and submergence factor) and their ratios;
2. calibration: the pre-start phase to a start of 0.1 h into a 2 ha polder, the open breach solved there, and
   the weir calibrated on it (``Timeline.calibrate``); prints each step, then the calibrated weir against the
   solver with the polder dry (a state it was not calibrated on).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _setup(text, path=None, **changes):
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario.config import parse_scenario
    from breachflow.scenario.toml import scenario_with

    return closure_setup(parse_scenario(scenario_with(text, changes), path))


def main(argv=None) -> int:
    from breachflow.cycle.criteria import section_discharge

    args = list(sys.argv[1:] if argv is None else argv)
    res = "1 m"
    if "--resolution" in args:
        k = args.index("--resolution")
        res = args[k + 1]
        del args[k:k + 2]
    path = Path(args[0]) if args else ROOT / "tests" / "data" / "ci_closure.toml"
    text = path.read_text()
    base = {"closure.method": "split_barge", "hydro.resolution": res, "hydro.t_max_initial": "300 s"}

    s = _setup(text, path, **{**base, "polder.area": "8 ha"})
    tl = s.timeline
    head = tl.flood_level - s.bottom
    print(f"breach bottom {s.bottom:g} m, flood level {tl.flood_level:g} m, breach {tl.length:g} m, "
          f"walls {tl.wall_slope:g}; cells {res}")
    print("tail/H   solver m3/s   weir m3/s   solver/weir   solver/free   Fread k_s")
    free = None
    for frac in (0.0, 0.50, 0.67, 0.76, 0.85, 0.92):
        tl.polder_level = s.bottom + frac * head if frac > 0 else tl.polder.initial_level
        c0 = time.process_time()
        q = section_discharge(s.solver.solve(s.domain), s.breach_x, s.levee_y)
        qw = tl.weir(0.0, tl.polder_level)
        free = q if free is None else free
        ks = qw / tl.weir(0.0, tl.polder.initial_level)
        print(f"{frac:6.2f}   {q:11.2f}   {qw:9.2f}   {q / qw:11.3f}   {q / free:11.3f}   {ks:9.3f}"
              f"   ({time.process_time() - c0:.1f} CPU s)", flush=True)

    s = _setup(text, path, **{**base, "closure.start": "0.1 h", "polder.area": "2 ha"})
    tl = s.timeline
    tl.begin()
    snap = s.solver.solve(s.domain)
    snap = tl.calibrate(snap, lambda prev: s.solver.solve(s.domain, initial=prev),
                        lambda sn: section_discharge(sn, s.breach_x, s.levee_y))
    print("calibration at the start (0.1 h, 2 ha polder):")
    for k, step in enumerate(tl.calibration):
        print(f"  step {k}: coefficient {step['weir_coefficient']:.4f} m^0.5/s, polder {step['polder_level']:.3f} m, "
              f"weir {step['weir_discharge']:.2f} m3/s, solver {step['model_discharge']:.2f} m3/s "
              f"({step['weir_discharge'] / step['model_discharge'] - 1:+.1%})")
    tl.polder_level = tl.polder.initial_level
    q_dry = section_discharge(s.solver.solve(s.domain), s.breach_x, s.levee_y)
    qw = tl.weir(tl.start, tl.polder_level)
    print(f"calibrated weir with the polder dry: {qw:.2f} m3/s against the solver's {q_dry:.2f} ({qw / q_dry - 1:+.1%})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
