"""The typical breach's open-breach flow on a sequence of grids: does it converge, and where is its control?

    python3 tasks.py bench gap_convergence [--grids 8,4,2,4/2,4/1] [--wall-slope 0] [--scenario FILE] [--json FILE]

``examples/typical_breach.toml`` as shipped with only ``[hydro] resolution`` (``8``: uniform 8 m cells) or
``resolution`` and ``refine`` (``4/1``: a nested 1 m grid at the breach in the 4 m solve, its terrain from the
preset's analytic geometry) changed, and with ``--wall-slope`` the breach walls' slope ``m_W`` (horizontal per
vertical; 0: the preset's vertical walls; the report: "vertical to 1V:1H, mostly 2V:1H", 0.5). The open breach
(``--scenario``: another scenario, e.g. the embedded default ``src/breachflow/data/closure_default.toml``)
is solved cold to its steady state (the closure's first solve), each grid in a fresh child process. Printed
per grid, on the sections ``y = const`` of the breach channel (its rows, linearly interpolated to the exact
section as :func:`breachflow.swe.section.section_speeds` does):

* the open width of the levee line's section and the breach discharge ``Q`` (the closure's definition);
* the gap speed on the levee line: depth-weighted mean and max (the check's figures);
* the control section (:func:`breachflow.cycle.criteria.control_speed`): the first section of the breach
  channel, with the flow, where the section Froude number ``Fr = Q / (A √(g A / T))`` (A the wet area, T the
  wet width) reaches 1, its position and its mean speed ``Q / A_c`` — at a critical section the critical
  speed, set by the discharge alone (``(g Q / T)^{1/3}`` on a rectangle, printed with T the levee line's
  wet width: the broad-crested weir's control);
* the mean speed over the channel ``Q / A`` averaged over the sections between the entrance (the flood-side
  toe) and the levee line, and the CPU seconds of the solve (``time.process_time`` of the child).
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

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
GRAVITY = 9.81


DEFAULT = ROOT / "examples" / "typical_breach.toml"


def scenario_text(res: float, refine: float | None, wall_slope: float, scenario=DEFAULT) -> str:
    text = Path(scenario).read_text()
    grid = f'resolution = "{res:g} m"' + (f'\nrefine = "{refine:g} m"' if refine else "")
    text = re.sub(r'^resolution = .*$', grid, text, count=1, flags=re.M)
    if wall_slope:
        text += f'\n[breach]\nlength = "61 m"\ndepth = "7.6 m"\nwall_slope = {wall_slope:g}\n'
    return text


def sections(snap, x_range, ys):
    """Per section ``y`` in *ys*: (wet area A, wet width T, discharge Q through it, depth-weighted mean speed)."""
    from breachflow.swe.section import open_wet

    x = snap["x"].values
    y = snap["y"].values
    dx = abs(x[1] - x[0])
    h = snap["depth"].values
    qy = h * snap["v"].values
    qx = h * snap["u"].values
    ow = open_wet(snap) & (h > 1e-3)
    sel = (x >= x_range[0]) & (x <= x_range[1])
    out = []
    for y0 in ys:
        j = int(np.clip(np.searchsorted(y, y0) - 1, 0, y.size - 2))
        w = (y0 - y[j]) / (y[j + 1] - y[j])
        a = np.where(ow[j, sel], 1.0 - w, 0.0)
        b = np.where(ow[j + 1, sel], w, 0.0)
        s = a + b
        ok = s > 0
        a, b = np.where(ok, a / np.where(ok, s, 1), 0), np.where(ok, b / np.where(ok, s, 1), 0)
        hh = a * h[j, sel] + b * h[j + 1, sel]
        qq = a * qy[j, sel] + b * qy[j + 1, sel]
        qs = np.hypot(qq, a * qx[j, sel] + b * qx[j + 1, sel])
        A = float(np.sum(hh) * dx)
        T = float(np.count_nonzero(hh > 1e-3) * dx)
        out.append((A, T, float(np.sum(qq) * dx), float(np.sum(qs) / max(np.sum(hh), 1e-12))))
    return out


def child(res: float, refine: float | None, wall_slope: float, result: str, scenario=DEFAULT) -> None:
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import control_speed, gap_section_speeds, section_discharge
    from breachflow.scenario import load_scenario

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "s.toml"
        path.write_text(scenario_text(res, refine, wall_slope, scenario))
        t0 = time.process_time()
        setup = closure_setup(load_scenario(path))
        snap = setup.solver.solve(setup.domain)
        cpu = time.process_time() - t0
    xr_, y0 = setup.breach_x, setup.levee_y
    q = section_discharge(snap, xr_, y0)
    gmax, gmean = gap_section_speeds(snap, xr_, y0)
    x = snap["x"].values
    dx = abs(x[1] - x[0])
    ys = np.arange(-33.4, 33.4 + 1e-9, 0.5)  # the levee footprint: flood-side toe to protected-side toe
    sec = sections(snap, xr_, ys)
    fr = np.array([Q / (A * np.sqrt(GRAVITY * A / T)) if A > 0 and T > 0 else np.nan for A, T, Q, _ in sec])
    A = np.array([s[0] for s in sec])
    yc, vc = control_speed(snap, xr_, y0)
    jl = int(np.argmin(np.abs(ys - y0)))
    row = sec[jl]
    out = {"res": res, "refine": refine, "wall_slope": wall_slope, "dx": dx, "cpu": cpu,
           "q": q, "gap_mean": gmean, "gap_max": gmax, "open_width": row[1], "area_levee_line": row[0],
           "fr_levee_line": float(fr[jl]),
           "y_control": yc, "v_control": vc, "v_critical": (GRAVITY * q / row[1]) ** (1 / 3),
           "v_channel": float(np.mean(q / A[: jl + 1])),
           "converged": int(snap.attrs.get("steady_state", 0)), "t": float(snap.attrs.get("simulated_time_s", np.nan))}
    Path(result).write_text(json.dumps(out))


def main(argv) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grids", default="8,4,2,4/2,4/1")
    ap.add_argument("--wall-slope", type=float, default=0.0)
    ap.add_argument("--json")
    ap.add_argument("--scenario", default=str(DEFAULT), help="another scenario (its [hydro] resolution changed)")
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        res, ref, ws, result = a.child
        child(float(res), float(ref) or None, float(ws), result, a.scenario)
        return 0
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for g in a.grids.split(","):
            res, _, ref = g.partition("/")
            result = str(Path(d) / f"r{len(rows)}.json")
            subprocess.run([sys.executable, __file__, "--scenario", a.scenario, "--child", res, ref or "0",
                            str(a.wall_slope), result], check=True)
            r = json.loads(Path(result).read_text())
            rows.append(r)
            label = f"{r['res']:g} m" + (f" nested {r['refine']:g} m" if r["refine"] else "")
            vc = f"{r['v_control']:.3f} m/s at y = {r['y_control']:+.1f} m ((g Q / T)^(1/3) {r['v_critical']:.3f})"
            print(f"wall slope {a.wall_slope:g} | {label} (cells {r['dx']:.3f} m) | open {r['open_width']:.2f} m | "
                  f"Q {r['q']:.1f} m3/s | gap mean {r['gap_mean']:.3f} max {r['gap_max']:.3f} m/s | "
                  f"Fr(levee line) {r['fr_levee_line']:.2f} | control {vc} | channel Q/A {r['v_channel']:.3f} m/s | "
                  f"CPU {r['cpu']:.1f} s | steady {r['converged']} t {r['t']:.0f} s", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
