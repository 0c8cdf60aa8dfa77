"""The closure window of a scenario's breach left open, without a closure: the window weir's calibration and the window.

    python benchmarks/dev/open_breach_window.py SCENARIO [--resolution M] [--starts H ...] [--coefficients C ...]
        [--start-levels Z ...]

*SCENARIO* is a closure scenario in time (``[closure] method``, ``[polder]``). The breach is solved at the reference
state of the window's weir (the open breach at its full size, :meth:`breachflow.cycle.timeline.Timeline.calibrate_window`:
one cold solve without a growth law, up to ``calibration_solves`` + 1 with one), and printed: the reference state, the
coefficient, the flow model's and the weir's discharges, the window (balance; and the inundation limit when
``[polder] inundation_depth`` is given), the polder level at the start by the window's weir and the CPU
seconds. ``--starts`` repeats it with the closure started at
those times (h after the breach): the window must not move. ``--coefficients`` prints the window the weir would give
with other coefficients (m^0.5/s, e.g. those calibrated at a run's start: ``metadata.timeline_start.weir_coefficient``
of its manifest), by the timeline alone. ``--start-levels`` solves the open breach cold at the scenario's start
with the polder at those levels (m), e.g. those of a run's start calibration (``metadata.timeline_start.weir_calibration``).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--resolution", type=float, default=None, help="[hydro] resolution (m)")
    ap.add_argument("--starts", type=float, nargs="*", default=[], help="closure starts to repeat it for (h)")
    ap.add_argument("--coefficients", type=float, nargs="*", default=[], help="other weir coefficients (m^0.5/s)")
    ap.add_argument("--start-levels", type=float, nargs="*", default=[],
                    help="cold solves of the open breach at the scenario's start with these polder levels (m)")
    a = ap.parse_args(argv)

    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import section_discharge
    from breachflow.scenario.config import parse_scenario
    from breachflow.scenario.toml import scenario_with

    base = a.scenario.read_text(encoding="utf-8")
    if a.resolution is not None:
        base = scenario_with(base, {"hydro.resolution": f"{a.resolution:g} m"})
    starts = [None] + list(a.starts)
    for start in starts:
        text = base if start is None else scenario_with(base, {"closure.start": f"{start:g} h"})
        sc = parse_scenario(text)
        s = closure_setup(sc)
        tl = s.timeline
        d_i = None if "polder" not in sc or sc["polder"].inundation_depth is None else float(sc["polder"].inundation_depth)
        tl.begin()
        c0 = time.process_time()
        tl.calibrate_window(lambda: s.solver.solve(s.domain),
                            lambda snap: section_discharge(snap, s.breach_x, s.levee_y, s.flow_sign))
        cpu = time.process_time() - c0
        cal = tl.window_calibration
        w = tl.open_breach_window(d_i)
        z_start = tl.polder_level  # the start's polder with the report's coefficient (before the start's calibration)
        c_start, tl.weir_coefficient = tl.weir_coefficient, tl.window_coefficient
        tl.begin()
        z_window = tl.polder_level  # ... and with the window's
        tl.weir_coefficient = c_start
        print(f"start {tl.start / 3600:g} h: reference {cal['time_s'] / 3600:.2f} h after the breach (breach "
              f"{cal['breach_length_m']:.1f} m, flood {cal['flood_level_m']:.2f} m, polder {cal['polder_level_m']:.2f} m); "
              f"weir coefficient {cal['weir_coefficient']:.4f} m^0.5/s ({len(cal['steps'])} step(s), the report's "
              f"{cal['steps'][0]['weir_coefficient']:.4f}); flow model {cal['model_discharge_m3_s']:,.1f} m3/s, weir "
              f"{cal['weir_discharge_m3_s']:,.1f} m3/s; window {w / 3600:.2f} h; polder at the start {z_window:.2f} m by the "
              f"window's weir ({z_start:.2f} m by the report's); {cpu:.1f} CPU s", flush=True)
        if start is None:
            tl.begin()
            for z in a.start_levels:  # e.g. the levels of a run's start calibration (its weir_calibration steps)
                tl.polder_level = z
                c0 = time.process_time()
                q = section_discharge(s.solver.solve(s.domain), s.breach_x, s.levee_y, s.flow_sign)
                print(f"   polder {z:.2f} m at the start: cold solve {q:,.1f} m3/s ({time.process_time() - c0:.1f} CPU s)")
            tl.begin()
            for c in a.coefficients:
                tl.window_coefficient = c
                print(f"   with the coefficient {c:.4f} m^0.5/s: window {tl.open_breach_window(d_i) / 3600:.2f} h")


if __name__ == "__main__":
    main()
