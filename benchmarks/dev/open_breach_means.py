"""The verdict check's open-breach comparison on its own: both grids solved, marched on and compared as time means.

    python benchmarks/dev/open_breach_means.py SCENARIO [--weir C] [--windows N] [--grid uniform|nested]
        [--out FILE.json]

Solves the open breach of a closure scenario in time on the scenario's grid and on the next finer one (the cell
size halved, or a nested grid of half the cell size: ``--grid``), each from rest with the weir calibration begun
from *C* (m^0.5/s; the run's ``metadata.timeline_start.weir_coefficient``, as the check does), marches each on for
*N* steady windows (:func:`breachflow.ensemble.check.open_breach_mean`) and prints both grids' time means with
their errors, their CPU time and the check's reading of the grid difference (:func:`breachflow.ensemble.check.judge`
on the two open breaches). docs/verdict-check.md, *The open breach's flow as a time mean*.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--weir", type=float, default=None, help="weir coefficient the calibration begins from (m^0.5/s)")
    ap.add_argument("--windows", type=int, default=None, help="steady windows marched (default: [check] flow_mean_windows)")
    ap.add_argument("--grid", choices=("uniform", "nested"), default=None, help="the finer grid (default: [check] grid)")
    ap.add_argument("--out", type=Path, default=None, help="both open breaches (JSON)")
    a = ap.parse_args(argv)

    from breachflow.ensemble.check import CheckSection, _open_breach_on, judge
    from breachflow.scenario import parse_scenario

    sc = parse_scenario(a.scenario.read_text(), path=a.scenario)
    section = dataclasses.replace(sc.get("check") or CheckSection())
    if a.grid:
        section.grid = a.grid
    windows = section.flow_mean_windows if a.windows is None else a.windows
    res = float(sc["hydro"].resolution)
    runs = []
    for fine in (False, True):
        r = _open_breach_on(sc, a.scenario, res, section, a.weir, fine=fine, windows=windows)
        runs.append(r)
        print(f"{r.label}: Q {r.discharge:.1f} ± {r.discharge_error:.1f} m3/s, control {r.control_speed:.4f} ± "
              f"{r.control_speed_error:.4f} m/s, gap mean {r.gap_mean_speed:.4f} ± {r.gap_mean_speed_error:.4f} m/s "
              f"(mean over {r.mean_interval:.1f} s; {r.cpu:.1f} CPU s)", flush=True)
    result = judge(runs, section.tolerance)
    for name, value in result.flow_difference.items():
        print(f"grid difference of the {name}: {100 * value:+.2f} ± {100 * result.flow_difference_error[name]:.2f} %")
    print("statement:", result.verdict)
    if a.out:
        a.out.write_text(json.dumps({"runs": [dataclasses.asdict(r) for r in runs], "statement": result.verdict,
                                     "flow_difference": result.flow_difference,
                                     "flow_difference_error": result.flow_difference_error}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
