"""Critical velocity of a stone on a rock bed from the DEM + fluid forces vs Izbash and Shields.

``python pipelines/stone_stability.py OUT [DRAG_LAW] [--from-csv]`` sweeps D in 0.1–2 m and h in 1–10 m for the
velocity profiles ``uniform``, ``log`` and ``power`` (:func:`breachflow.studies.stability.critical_velocity`),
prints the table and per profile the bands of the Izbash coefficient ``U / sqrt(2 g Delta D)`` for three
reference velocities — the depth-averaged ``U_c`` over the whole sweep, ``U_c`` where ``h/D`` is in
Izbash's range 5–10, and the near-stone velocity ``u_b`` at ``z = D`` (:func:`near_bed_velocity`, the
velocity Izbash's coefficient refers to) — and of ``U_c / U_Shields``; writes
``OUT/stone_stability_DRAG_LAW.csv`` and ``.png`` (top: ``U_c`` with Izbash and Shields; bottom: ``u_b``
with Izbash). ``--from-csv`` takes ``U_c`` from an existing CSV (no DEM runs) and recomputes the rest.
"""
from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

PROFILES = ("uniform", "log", "power")
IZBASH_RANGE = (5.0, 10.0)  # h/D where Izbash is applied to the depth-averaged velocity


def main(out="stone_stability", drag_law="report", from_csv=False):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from breachflow.studies.stability import critical_velocity, near_bed_velocity
    from breachflow.scenario.stone import izbash_velocity, shields_velocity

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"stone_stability_{drag_law}.csv"
    Ds = [0.1, 0.2, 0.5, 1.0, 2.0]
    hs = [1.0, 3.0, 10.0]
    known = {}
    if from_csv:
        with open(path) as f:
            known = {(r["profile"], float(r["D_m"]), float(r["h_m"])): float(r["U_c_m_s"]) for r in csv.DictReader(f)}
    rows = []
    for prof in PROFILES:
        for h in hs:
            for D in Ds:
                if D > 0.5 * h:
                    continue
                uc = known[(prof, D, h)] if from_csv else critical_velocity(D, h, velocity_profile=prof,
                                                                            drag_law=drag_law)
                s = math.sqrt(2 * 9.80665 * 1.65 * D)
                ub = float(near_bed_velocity(uc, D, h, velocity_profile=prof))
                rows.append((prof, D, h, uc, uc / s, float(uc / shields_velocity(D, h)), ub, ub / s))
                print(f"{prof:8s} D={D:4.1f} m h={h:4.1f} m  U_c={uc:6.3f} m/s  C_izbash={rows[-1][4]:.3f}  "
                      f"U_c/U_shields={rows[-1][5]:.3f}  u_b={ub:6.3f} m/s  C_izbash(u_b)={rows[-1][7]:.3f}", flush=True)
    with open(path, "w") as f:
        f.write("profile,D_m,h_m,U_c_m_s,izbash_coefficient,ratio_to_shields,u_b_m_s,izbash_coefficient_u_b\n")
        for r in rows:
            f.write(",".join(str(v) for v in r) + "\n")
    for prof in PROFILES:
        sel = [r for r in rows if r[0] == prof]
        c = [r[4] for r in sel]
        cr = [r[4] for r in sel if IZBASH_RANGE[0] <= r[2] / r[1] <= IZBASH_RANGE[1]]
        cb = [r[7] for r in sel]
        s = [r[5] for r in sel]
        print(f"{prof}: Izbash coefficient U_c {min(c):.2f}-{max(c):.2f} (h/D 5-10: {min(cr):.2f}-{max(cr):.2f}), "
              f"u_b {min(cb):.2f}-{max(cb):.2f}; U_c/U_Shields {min(s):.2f}-{max(s):.2f}")
    fig, axes = plt.subplots(2, 3, figsize=(14, 8), sharey="row", sharex=True)
    Dline = np.geomspace(0.1, 2.0, 50)
    for col, h in enumerate(hs):
        for row in (0, 1):
            ax = axes[row, col]
            ax.plot(Dline, izbash_velocity(Dline, placement="exposed"), "k--", label="Izbash exposed (0.86)")
            ax.plot(Dline, izbash_velocity(Dline, placement="embedded"), "k:", label="Izbash embedded (1.2)")
            if row == 0:
                ax.plot(Dline, shields_velocity(Dline, h), "k-", lw=0.8, label="Shields 0.047, log law k_s=2D")
            for prof, m in (("uniform", "o"), ("log", "s"), ("power", "^")):
                k = 3 if row == 0 else 6
                pts = [(r[1], r[k]) for r in rows if r[0] == prof and r[2] == h]
                if pts:
                    ax.plot(*zip(*pts), m, label=f"DEM, profile {prof}")
            ax.set_xscale("log")
        axes[0, col].set_title(f"h = {h:g} m, drag law {drag_law}")
        axes[1, col].set_xlabel("stone diameter D (m)")
    axes[0, 0].set_ylabel("critical depth-averaged velocity U_c (m/s)")
    axes[1, 0].set_ylabel("velocity at z = D above the bed at U_c (m/s)")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / f"stone_stability_{drag_law}.png", dpi=110)
    print(out / f"stone_stability_{drag_law}.png")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(*args[:2], from_csv="--from-csv" in sys.argv[1:])
