"""Is ``contact_law = "hooke_history"`` LAMMPS' law? Small scenes run in both codes (issue 16).

    python3 tasks.py bench dem_law

Scenes of bench_dem.py's material (d = 1 m, kn = kt = 1e7 N/m, e = 0.5, mu 0.5, dt = 1e-3 s, gravity,
floor plane at z = 0 — LAMMPS ``fix wall/gran hooke/history`` with the halved dashpot of bench_dem.py):
two spheres colliding obliquely with spin in the air (pair law only), and one sphere hitting the floor
obliquely with spin (wall law). Printed after 20 and 200 steps: mean height breachflow − LAMMPS and the
kinetic energy of each (breachflow ``velocity_verlet`` + ``hooke_history`` / LAMMPS). Needs LAMMPS as in
bench_dem.py.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

CASES = {
    "pair in the air": (np.array([[3.0, 4.0, 5.0], [3.99, 4.2, 5.05]]), np.array([[1.0, 0.2, 0.0], [-1.0, 0.0, 0.3]]),
                        np.array([[0.0, 0.0, 3.0], [1.0, 0.0, 0.0]])),
    "sphere on the floor": (np.array([[4.0, 4.0, 0.52]]), np.array([[1.5, 0.3, -1.0]]), np.array([[0.0, 2.0, 0.0]])),
}


def main(argv) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem as b

    env = b.ensure_lammps()
    if env is None:
        print("LAMMPS is not available")
        return 1
    L = 8.0
    for name, (pos, vel, om) in CASES.items():
        n = pos.shape[0]
        for steps in (20, 200):
            lam = b.run_lammps((pos, vel, om), np.full(n, 0.5), np.full(n, b.RHO), L, steps, env)
            sim = b.make_sim(pos, vel, L, "velocity_verlet", omega=om, law="hooke_history")
            sim.step(steps)
            zb, kb = b.summary(sim)
            print(f"{name:20s} {steps:4d} steps: mean z breachflow - LAMMPS {zb - lam[1][0]:+.2e} m; "
                  f"KE breachflow / LAMMPS {kb:.6e} / {lam[1][1]:.6e} J (rel. {kb / lam[1][1] - 1:+.1e})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
