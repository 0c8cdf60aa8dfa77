"""Ritter and Stoker dam breaks along a channel: L1 depth errors against the analytic solutions,
observed orders under refinement, and a cross-check against the SWASHES program (same parameters:
L = 10 m, dam at 5 m, t = 6 s, Stoker h_l = 0.005 m / h_r = 0.001 m, Ritter h_l = 0.005 m)."""
import numpy as np
import pytest

from .analytic import ritter, stoker, swashes
from ._util import cell_average, channel, observed_orders, run

H_L, H_R, X_DAM, T_END, LENGTH = 0.005, 0.001, 5.0, 6.0, 10.0


def reference(kind):
    if kind == "stoker":
        return lambda x: stoker(x, T_END, H_L, H_R, X_DAM)[0]
    return lambda x: ritter(x, T_END, H_L, X_DAM)[0]


def l1_error(kind, n, order):
    right = H_R if kind == "stoker" else np.nan
    dom = channel(n, LENGTH, lambda X, Y: np.where(X < X_DAM, H_L, right))
    sim = run(dom, T_END, order=order)
    exact = cell_average(reference(kind), dom.x, dom.dx)
    return float(np.abs(sim.depth[0] - exact).sum() * dom.dx), sim


def convergence(kind, order, grids):
    errors = [l1_error(kind, n, order)[0] for n in grids]
    orders = observed_orders(errors)
    print(f"\n{kind} order {order}: " + ", ".join(f"N={n}: L1={e:.3e}" for n, e in zip(grids, errors))
          + " | observed orders " + ", ".join(f"{p:.2f}" for p in orders))
    return np.array(errors), orders


# Both solutions are only Lipschitz (rarefaction corners, the dry front) or discontinuous (the shock):
# the L1 error of any consistent scheme then converges at most at first order. The second-order scheme
# must reach that rate; the first-order scheme converges more slowly on the rarefaction corners
# (between 1/2 and 1) and must have the larger error.
@pytest.mark.parametrize("kind", ["stoker", "ritter"])
def test_dam_break_l1_error_converges_at_the_expected_order(kind):
    grids = [100, 200, 400, 800]
    e2, p2 = convergence(kind, 2, grids)
    e1, p1 = convergence(kind, 1, grids)
    assert np.all(np.diff(e2) < 0) and np.all(np.diff(e1) < 0)
    assert p2.mean() > 0.85 and p2.min() > 0.7
    assert p1.mean() > 0.5
    assert np.all(e2 < e1)
    # accuracy relative to the water volume involved: below 1 % of h_L * L on 800 cells
    assert e2[-1] < 0.01 * H_L * LENGTH


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["stoker", "ritter"])
def test_dam_break_convergence_on_fine_grids(kind):
    grids = [400, 800, 1600, 3200, 6400]
    e2, p2 = convergence(kind, 2, grids)
    e1, p1 = convergence(kind, 1, grids)
    assert np.all(np.diff(e2) < 0) and p2.mean() > 0.9
    assert np.all(np.diff(e1) < 0) and p1.mean() > 0.6


@pytest.mark.parametrize("kind, choice", [("stoker", 1), ("ritter", 2)])
def test_dam_break_cross_check_with_swashes(kind, choice):
    n = 400
    table = swashes(1, 3, 1, choice, n)                       # columns: x, h, u, topo, q, ...
    x_sw, h_sw = table[:, 0], table[:, 1]
    # the independent SWASHES implementation agrees with the references written in these tests
    # (SWASHES prints 7 significant digits)
    np.testing.assert_allclose(h_sw, reference(kind)(x_sw), rtol=1e-5, atol=1e-6 * H_L)
    err, sim = l1_error(kind, n, 2)
    np.testing.assert_allclose(sim.domain.x, x_sw, atol=1e-9)
    err_sw = float(np.abs(sim.depth[0] - h_sw).sum() * sim.domain.dx)
    assert err_sw < 2.5e-3 * H_L * LENGTH
    # unit discharge agrees as well (relative L1)
    q_sim = sim.discharge[0][0]
    q_sw = table[:, 1] * table[:, 2]
    assert np.abs(q_sim - q_sw).sum() / np.abs(q_sw).sum() < 0.05
