"""Uniform (normal-depth) Manning flow down a sloping channel through outflow-type boundaries (issue 12).

Reference: Manning's normal depth ``h_n = (q n / sqrt(S))^(3/5)`` of a wide channel (unit discharge q,
bed slope S). A channel started at ``h_n`` with ``q`` everywhere, fed with ``q`` at its upstream end,
must stay there: the outlet boundary may not pond the water (a flat ghost bed forced the surface flat at
the outlet: +100 % depth there, +87 % mid-reach) nor drain it. Flow along +x, -x, +y and -y; order 2
(the default) and 1; several resolutions; a grid whose origin and spacing are arbitrary.
"""
import numpy as np
import pytest

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

DIRECTION = {"east": (1, 0), "west": (-1, 0), "north": (0, 1), "south": (0, -1)}
OPPOSITE = {"east": "west", "west": "east", "north": "south", "south": "north"}


def normal_depth(q, n, slope):
    return (q * n / slope**0.5) ** 0.6


def channel_run(outlet, order, dx, *, slope=1e-3, n=0.03, q=2.0, x0=0.0, y0=0.0, length=1000.0, width=3,
                kind="outflow", t_end=1500.0, start=1.0, steady=False):
    """Straight channel of *width* cells across, flowing towards side *outlet*, walls along its sides.

    Returns ``(h_n, depth, discharge along the flow)`` with the flow index 0 at the inlet."""
    ex, ey = DIRECTION[outlet]
    hn = normal_depth(q, n, slope)
    along_x = ex != 0
    x1 = x0 + (length if along_x else width * dx)
    y1 = y0 + (width * dx if along_x else length)
    bed = lambda X, Y: 25.0 - slope * (ex * X + ey * Y)
    probe = uniform_grid(x0, x1, y0, y1, dx, bed=bed)
    side = OPPOSITE[outlet]
    if q / hn > (9.81 * hn) ** 0.5:  # supercritical: depth and discharge imposed at the inlet
        z_in = {"west": probe.bed[:, 0], "east": probe.bed[:, -1], "south": probe.bed[0], "north": probe.bed[-1]}[side]
        inlet = BC.inflow(q, level=z_in + hn)
    else:
        inlet = BC.inflow(q)
    # a level far below the bed: the outflow is supercritical and the level boundary is free
    out = BC.outflow() if kind == "outflow" else BC.water_level(-100.0)
    dom = uniform_grid(x0, x1, y0, y1, dx, bed=bed, manning=n, boundaries={outlet: [out], side: [inlet]})
    shape = dom.shape
    sim = SWESimulation(dom, SWEOptions(order=order),
                        initial=(np.full(shape, start * hn), np.full(shape, q * ex), np.full(shape, q * ey)))
    if steady:
        hist = sim.run_to_steady(tolerance=1e-7, t_max=t_end)
        assert hist.converged
    else:
        sim.advance_to(t_end)
    h = sim.depth
    qa = ex * sim.discharge[0] + ey * sim.discharge[1]
    if not along_x:
        h, qa = h.T, qa.T
    if ex < 0 or ey < 0:
        h, qa = h[:, ::-1], qa[:, ::-1]
    return hn, h, qa


@pytest.mark.parametrize("outlet", ["east", "west", "north", "south"])
@pytest.mark.parametrize("dx", [20.0, 10.0])
def test_uniform_subcritical_flow_keeps_its_normal_depth_at_second_order(outlet, dx):
    hn, h, q = channel_run(outlet, 2, dx)
    err = (h - hn) / hn
    # away from the inlet cells (where the extrapolated inflow depth disturbs by < 1 %) to 2e-4,
    # outlet included; the discharge is the fed one there
    assert np.abs(err[:, 3:]).max() < 2e-4, np.abs(err).max(axis=0)[-5:]
    assert np.abs(err[:, -1]).max() < 2e-4
    assert np.abs(err).max() < 0.01
    np.testing.assert_allclose(q[:, 3:], 2.0, rtol=2e-3)


@pytest.mark.parametrize("outlet", ["east", "north"])
def test_uniform_flow_first_order_converges_to_the_normal_depth(outlet):
    """Order 1, steady state: the hydrostatic reconstruction's O(dx) error (-0.26 % at 10 m), uniform
    along the reach and halved with the cell size; no growth towards the outlet."""
    errs = []
    for dx in (20.0, 10.0, 5.0):
        hn, h, q = channel_run(outlet, 1, dx, length=500.0, t_end=6000.0, steady=True)
        err = (h - hn) / hn
        assert np.abs(err).max() < 6e-4 * dx / 2.0
        # outlet cell as good as the middle of the reach (within 10 % of the scheme's own error)
        mid = err[1, h.shape[1] // 2]
        assert abs(err[1, -1] - mid) < 0.1 * abs(mid)
        # the cell-centred discharge of first-order hydrostatic reconstruction is off by O(dx) too
        np.testing.assert_allclose(q[:, 3:], 2.0, rtol=7e-4 * dx)
        errs.append(np.abs(err[:, 3:]).max())
    assert errs[0] / errs[1] > 1.7 and errs[1] / errs[2] > 1.7


@pytest.mark.parametrize("kind", ["outflow", "level"])
@pytest.mark.parametrize("outlet", ["east", "south"])
def test_uniform_supercritical_flow_through_an_outflow_or_a_free_level_boundary(kind, outlet):
    """Steep channel (S = 0.01, n = 0.02: Froude 1.46). The inlet's imposed state settles within ~20
    cells; the lower half of the reach and the outlet cell keep the normal depth."""
    hn, h, q = channel_run(outlet, 2, 10.0, slope=0.01, n=0.02, kind=kind, t_end=600.0)
    err = (h - hn) / hn
    half = h.shape[1] // 2
    assert np.abs(err[:, half:]).max() < 1e-5
    np.testing.assert_allclose(q[:, half:], 2.0, rtol=1e-5)


def test_uniform_flow_on_a_grid_not_aligned_with_anything():
    """Arbitrary origin, extent and cell size (7.7 m requested, 7.7045 m fitted), flow towards -y,
    started 30 % too deep: the steady state is the normal depth."""
    hn, h, q = channel_run("south", 2, 7.7, x0=-123.4, y0=371.9, length=1247.3, width=4, start=1.3,
                           t_end=6000.0, steady=True)
    err = (h - hn) / hn
    assert np.abs(err[:, 3:]).max() < 3e-4
    assert np.abs(err).max() < 0.01
    np.testing.assert_allclose(q[:, 3:], 2.0, rtol=2e-3)


def test_a_lake_at_rest_against_an_outflow_over_a_falling_bed_stays_at_rest():
    """The continued ghost bed does not drain a still lake: a flat surface counts as flat."""
    dom = uniform_grid(0, 200, 0, 30, 10.0, bed=lambda X, Y: 5.0 - 1e-3 * X, initial_surface=6.0,
                       boundaries={"east": [BC.outflow()]})
    sim = SWESimulation(dom).advance_to(600.0)
    np.testing.assert_allclose(sim.depth + dom.bed, 6.0, atol=1e-12, rtol=0)
    assert np.abs(sim.discharge[0]).max() < 1e-12
