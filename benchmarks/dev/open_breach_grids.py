"""The typical breach's open breach at the start of its closure on one grid: discharge, gap and control speeds, steady.

    python benchmarks/dev/open_breach_grids.py {u4,u2,n2} [--scenario examples/typical_breach.toml]
                                               [--t-max-initial SECONDS]

``u4`` the shipped 4 m grid, ``u2`` a uniform 2 m grid, ``n2`` a nested 2 m grid at the breach (``[hydro] refine``).
The closure's set-up is built, its timeline begun (the breach grown and the polder filled by the weir up to the
start), and the open breach solved once from cold at that state, without the weir calibration that a run makes
on it. Printed: the breach discharge, the mean and largest speed in the gap section, the control speed
(:func:`breachflow.cycle.criteria.control_speed`), the solver's steady flag, the polder and flood levels and
the CPU seconds of the solve (``time.process_time``).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("grid", choices=["u4", "u2", "n2"])
    ap.add_argument("--scenario", type=Path, default=ROOT / "examples" / "typical_breach.toml")
    ap.add_argument("--t-max-initial", type=float, default=None,
                    help="[hydro] t_max_initial (s) of the solve instead of the scenario's")
    a = ap.parse_args(argv)

    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import control_speed, gap_section_speeds, section_discharge
    from breachflow.scenario import parse_scenario

    text = a.scenario.read_text()
    if a.grid == "u2":
        text = text.replace('resolution = "4 m"', 'resolution = "2 m"')
    elif a.grid == "n2":
        text = text.replace('resolution = "4 m"', 'resolution = "4 m"\nrefine = "2 m"')
    if a.t_max_initial is not None:
        import re

        text = re.sub(r'(?m)^t_max_initial = .*$', f't_max_initial = "{a.t_max_initial:g} s"', text)
    s = closure_setup(parse_scenario(text, path=a.scenario))
    s.timeline.begin()
    c0 = time.process_time()
    snap = s.solver.solve(s.domain)
    cpu = time.process_time() - c0
    q = section_discharge(snap, s.breach_x, s.levee_y, getattr(s, "flow_sign", 1.0))
    gmax, gmean = gap_section_speeds(snap, s.breach_x, s.levee_y)
    _, ctl = control_speed(snap, s.breach_x, s.levee_y)
    print(f"{a.grid}: Q {q:.1f} m3/s, gap mean {gmean:.3f} max {gmax:.3f} m/s, control {ctl:.3f} m/s, "
          f"steady {bool(snap.attrs.get('steady_state'))}, polder {s.timeline.polder_level:.3f} m, "
          f"flood {s.timeline.flood_level:.3f} m, CPU {cpu:.1f} s")


if __name__ == "__main__":
    main()
