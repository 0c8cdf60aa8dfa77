"""Write validation figures of docs/validation.md: Stoker's and Ritter's dam breaks against their analytic
solutions (the cases of tests/swe/test_dam_breaks.py), depth profiles and L1 convergence; and the DEM's
restitution error against the closed form over contact-onset phases (tests/dem/impact_cases.py).

    python3 tasks.py shell python docs/figures/make_validation_figures.py

Prints the errors it plots.
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
from tests.swe.analytic import ritter, stoker  # noqa: E402  (the tests' independent closed forms)
from tests.swe._util import cell_average, channel, observed_orders, run  # noqa: E402
from tests.dem.impact_cases import phase_averaged_error  # noqa: E402

H_L, H_R, X_DAM, T_END, LENGTH = 0.005, 0.001, 5.0, 6.0, 10.0
GRIDS = (50, 100, 200, 400, 800)


def exact(kind):
    if kind == "stoker":
        return lambda x: stoker(x, T_END, H_L, H_R, X_DAM)[0]
    return lambda x: ritter(x, T_END, H_L, X_DAM)[0]


def solve(kind, n, order):
    right = H_R if kind == "stoker" else np.nan
    dom = channel(n, LENGTH, lambda X, Y: np.where(X < X_DAM, H_L, right))
    sim = run(dom, T_END, order=order)
    ref = cell_average(exact(kind), dom.x, dom.dx)
    return dom.x, sim.depth[0], float(np.abs(sim.depth[0] - ref).sum() * dom.dx)


def main() -> int:
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), constrained_layout=True)
    for row, kind in enumerate(("stoker", "ritter")):
        ax = axes[row, 0]
        xs = np.linspace(0, LENGTH, 2001)
        ax.plot(xs, 1e3 * exact(kind)(xs), "k-", lw=1.5, label="analytic")
        for n, style in ((100, "C1o"), (400, "C0-")):
            x, h, _ = solve(kind, n, 2)
            ax.plot(x, 1e3 * h, style, ms=3, lw=1, label=f"breachflow, {n} cells, 2nd order")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("depth (mm)")
        ax.set_title(f"{kind.capitalize()} dam break at t = {T_END:g} s")
        ax.legend(fontsize=8)
        ax = axes[row, 1]
        for order, marker in ((1, "s--"), (2, "o-")):
            errs = [solve(kind, n, order)[2] for n in GRIDS]
            orders = observed_orders(errs)
            print(f"{kind} order {order}: " + ", ".join(f"N={n}: L1={e:.3e}" for n, e in zip(GRIDS, errs))
                  + " | observed orders " + ", ".join(f"{p:.2f}" for p in orders))
            ax.loglog(LENGTH / np.array(GRIDS), errs, marker, label=f"order {order} (observed {orders[-1]:.2f})")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("cell size (m)")
        ax.set_ylabel("L1 depth error (m²)")
        ax.set_title(f"{kind.capitalize()}: convergence")
        ax.legend(fontsize=8)
    fig.savefig(HERE / "swe_dam_breaks.png", dpi=100)
    plt.close(fig)
    dem_impacts()
    return 0


def dem_impacts(steps=(10, 20, 40, 80)) -> None:
    """Mean |restitution error| of a sphere hitting a plane (zeta 0.3) over 32 onset / release phases."""
    fig, ax = plt.subplots(figsize=(6, 4.2), constrained_layout=True)
    for integrator, marker in (("predicted_verlet", "o-"), ("velocity_verlet", "s--")):
        errs = [phase_averaged_error("plane", 0.3, n, integrator) for n in steps]
        print(f"DEM impact, plane, zeta 0.3, {integrator}: " +
              ", ".join(f"{n} steps/contact {e:.4f} %" for n, e in zip(steps, np.array(errs) * 100)))
        ax.loglog(steps, 100 * np.array(errs), marker, label=integrator)
    ax.set_xlabel("time steps per contact")
    ax.set_ylabel("mean |restitution error| (%)")
    ax.set_title("sphere on a plane, damping ratio 0.3, step-averaged law", fontsize=10)
    ax.legend()
    fig.savefig(HERE / "dem_impacts.png", dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
