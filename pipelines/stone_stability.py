"""Critical velocity of a stone on a rock bed from the DEM + fluid forces vs Izbash and Shields.

``python pipelines/stone_stability.py OUT [DRAG_LAW]`` sweeps D in 0.1–2 m and h in 1–10 m for the velocity profiles
``uniform``, ``log`` and ``power`` (:func:`breachflow.fluid.stability.critical_velocity`), prints the
table, the band of U_c / sqrt(2 g Delta D) (Izbash coefficient) and of U_c / U_Shields per profile, and
writes ``OUT/stone_stability_DRAG_LAW.csv`` and ``.png``.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path


def main(out="stone_stability", drag_law="report"):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from breachflow.fluid.stability import critical_velocity
    from breachflow.scenario.stone import izbash_velocity, shields_velocity

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    Ds = [0.1, 0.2, 0.5, 1.0, 2.0]
    hs = [1.0, 3.0, 10.0]
    rows = []
    for prof in ("uniform", "log", "power"):
        for h in hs:
            for D in Ds:
                if D > 0.5 * h:
                    continue
                uc = critical_velocity(D, h, velocity_profile=prof, drag_law=drag_law)
                rows.append((prof, D, h, uc, uc / math.sqrt(2 * 9.80665 * 1.65 * D), uc / shields_velocity(D, h)))
                print(f"{prof:8s} D={D:4.1f} m h={h:4.1f} m  U_c={uc:6.3f} m/s  C_izbash={rows[-1][4]:.3f}  "
                      f"U_c/U_shields={rows[-1][5]:.3f}", flush=True)
    with open(out / f"stone_stability_{drag_law}.csv", "w") as f:
        f.write("profile,D_m,h_m,U_c_m_s,izbash_coefficient,ratio_to_shields\n")
        for r in rows:
            f.write(",".join(str(v) for v in r) + "\n")
    for prof in ("uniform", "log", "power"):
        c = [r[4] for r in rows if r[0] == prof]
        s = [r[5] for r in rows if r[0] == prof]
        print(f"{prof}: Izbash coefficient {min(c):.2f}-{max(c):.2f}; U_c/U_Shields {min(s):.2f}-{max(s):.2f}")
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), sharey=True)
    Dline = np.geomspace(0.1, 2.0, 50)
    for ax, h in zip(axes, hs):
        ax.plot(Dline, izbash_velocity(Dline, placement="exposed"), "k--", label="Izbash exposed (0.86)")
        ax.plot(Dline, izbash_velocity(Dline, placement="embedded"), "k:", label="Izbash embedded (1.2)")
        ax.plot(Dline, shields_velocity(Dline, h), "k-", lw=0.8, label="Shields 0.047, log law k_s=2D")
        for prof, m in (("uniform", "o"), ("log", "s"), ("power", "^")):
            pts = [(r[1], r[3]) for r in rows if r[0] == prof and r[2] == h]
            if pts:
                ax.plot(*zip(*pts), m, label=f"DEM, profile {prof}")
        ax.set_xscale("log")
        ax.set_title(f"h = {h:g} m, drag law {drag_law}")
        ax.set_xlabel("stone diameter D (m)")
    axes[0].set_ylabel("critical depth-averaged velocity (m/s)")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / f"stone_stability_{drag_law}.png", dpi=110)
    print(out / f"stone_stability_{drag_law}.png")


if __name__ == "__main__":
    main(*sys.argv[1:3])
