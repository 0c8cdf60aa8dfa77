"""The example site's open breach at the start of its closure on one grid: discharge, gap and control speeds.

    python benchmarks/dev/site_open_breach.py RESOLUTION [--scenario examples/site/site.toml] [--save FILE.nc]

*RESOLUTION* the ``[hydro] resolution`` of the solve (``1`` for the shipped 1 m grid, ``0.5`` for the verdict
check's finer grid). The closure's set-up is built and the open breach solved once from cold, as the run and
the check's finer-grid solve do. Printed: the breach discharge, the mean and largest speed in the gap section,
the control section (:func:`breachflow.cycle.criteria.control_speed`), the solver's steady flag and the CPU
seconds of the solve (``time.process_time``). ``--save`` writes the snapshot (NetCDF) for a closer look.
"""
from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("resolution", type=float, help="cell size, m")
    ap.add_argument("--scenario", type=Path, default=ROOT / "examples" / "site" / "site.toml")
    ap.add_argument("--save", type=Path, default=None, help="write the open-breach snapshot here (NetCDF)")
    a = ap.parse_args(argv)

    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import control_speed, gap_section_speeds, section_discharge
    from breachflow.scenario import parse_scenario

    text = re.sub(r'(?m)^resolution = "[^"]*"', f'resolution = "{a.resolution:g} m"', a.scenario.read_text())
    s = closure_setup(parse_scenario(text, path=a.scenario))
    if s.timeline is not None:
        s.timeline.begin()
    c0 = time.process_time()
    snap = s.solver.solve(s.domain)
    cpu = time.process_time() - c0
    q = section_discharge(snap, s.breach_x, s.levee_y, s.flow_sign)
    gmax, gmean = gap_section_speeds(snap, s.breach_x, s.levee_y)
    yc, ctl = control_speed(snap, s.breach_x, s.levee_y)
    print(f"{a.resolution:g} m: Q {q:.2f} m3/s, gap mean {gmean:.3f} max {gmax:.3f} m/s, control {ctl:.3f} m/s "
          f"at y {yc:.2f} m (levee {s.levee_y:.2f} m, breach x {s.breach_x[0]:.2f}..{s.breach_x[1]:.2f} m), "
          f"steady {bool(snap.attrs.get('steady_state'))}, CPU {cpu:.1f} s")
    if a.save is not None:
        ds = snap.copy()
        ds.attrs.update(breach_x0=float(s.breach_x[0]), breach_x1=float(s.breach_x[1]), levee_y=float(s.levee_y))
        ds.attrs = {k: (int(v) if isinstance(v, bool) else v) for k, v in ds.attrs.items()
                    if isinstance(v, (int, float, str, bool))}
        ds.to_netcdf(a.save)


if __name__ == "__main__":
    main()
