"""The breach's control section (:func:`breachflow.cycle.criteria.control_speed`): where the flow through the
breach channel passes critical depth, and its mean speed there — the critical speed ``(g q)^{1/3}`` of the
unit discharge, the gap speed the verdict check compares between grids.

Checked against closed forms: the frictionless transcritical flow over a hump (the SWASHES bump) in a walled
channel is critical at the crest, ``h_c = (q²/g)^{1/3}``, ``u_c = √(g h_c)``, on two grids with the crest off
the row centres; a made-up channel whose depth falls linearly along the flow has its critical section where
``h = h_c``; a drowned channel has none (its narrowest flow is taken); the judge compares that speed, not the
speed past the control."""
import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.criteria import control_speed
from breachflow.ensemble.check import CheckRun, judge
from breachflow.swe import SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

G = 9.81
Q = 1.53          # m²/s, SWASHES transcritical bump
H_OUT = 0.66
CREST = 10.0


def hump(Y):
    return np.where((Y > 8) & (Y < 12), 0.2 - 0.05 * (Y - CREST) ** 2, 0.0)


def walled(ds):
    """The channel snapshot with a closed column on each side (the breach walls)."""
    x = ds.x.values
    dx = x[1] - x[0]
    out = ds.reindex(x=np.concatenate([[x[0] - dx], x, [x[-1] + dx]]), fill_value=0.0)
    ob = np.zeros(out.depth.shape, "i1")
    ob[:, [0, -1]] = 1
    return out.assign(obstacle=(("y", "x"), ob), wet=(("y", "x"), (out.depth.values > 0).astype("i1")))


@pytest.mark.parametrize("dy", [0.5, 0.25])
def test_the_control_of_a_flow_over_a_hump_is_its_crest_at_the_critical_speed(dy):
    dom = uniform_grid(0.0, 3 * dy, dy / 4, dy / 4 + 25.0, dy, bed=lambda X, Y: hump(Y), initial_surface=H_OUT,
                       boundaries={"south": [BC.inflow(Q)], "north": [BC.water_level(H_OUT)]})
    sim = SWESimulation(dom)
    assert sim.run_to_steady(tolerance=1e-7, t_max=3000.0).converged
    ds = sim.snapshot()
    ds = walled(ds.assign_coords(x=ds.x - float(ds.x.mean())))
    yc, vc = control_speed(ds, (-1.25 * dy, 1.25 * dy), 5.0)
    hc = (Q * Q / G) ** (1.0 / 3.0)
    assert vc == pytest.approx(np.sqrt(G * hc), rel=0.01)
    assert abs(yc - CREST) <= 2 * dy


def channel(h, v, y, x=np.arange(-4.0, 5.0, 2.0)):
    Y, X = np.meshgrid(y, x, indexing="ij")
    H = np.broadcast_to(np.asarray(h, float)[:, None], Y.shape).copy()
    V = np.broadcast_to(np.asarray(v, float)[:, None], Y.shape).copy()
    ob = np.zeros(Y.shape, "i1")
    ob[:, [0, -1]] = 1
    H[:, [0, -1]] = 0.0
    return xr.Dataset({"depth": (("y", "x"), H), "u": (("y", "x"), 0 * H), "v": (("y", "x"), V),
                       "obstacle": (("y", "x"), ob), "wet": (("y", "x"), (H > 0).astype("i1"))},
                      coords={"x": x, "y": y})


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("offset", [0.0, 0.3, 1.1])
def test_the_critical_section_of_a_falling_surface_at_any_row_offset(sign, offset):
    """Depth falling linearly along the flow, unit discharge q: critical where h = h_c, speed (g q)^{1/3}
    (Fr = q / √(g h³) is monotonic, so the crossing is bracketed by two rows; linear interpolation of a
    smooth speed between rows 2 m apart: within 1 %)."""
    q = 28.0
    hc = (q * q / G) ** (1 / 3)
    y = np.arange(-30.0, 30.1, 2.0) + offset
    h = hc - sign * 0.04 * (y - 3.0)        # h_c at y = 3, deeper upstream
    ds = channel(h, sign * q / h, y)
    yc, vc = control_speed(ds, (-3.0, 3.0), 0.0)
    assert vc == pytest.approx((G * q) ** (1 / 3), rel=0.01)
    assert yc == pytest.approx(3.0, abs=0.1)


def with_film(ds, rows, side, film):
    """*ds* with the wall column(s) *side* ("west", "east", "both") opened on *rows* (a boolean per row) and
    holding water of depth *film* (m) at rest: the bank beside a breach head on a terrain site."""
    cols = {"west": [0], "east": [-1], "both": [0, -1]}[side]
    h, ob = ds.depth.values.copy(), ds.obstacle.values.copy()
    for c in cols:
        h[rows, c] = film
        ob[rows, c] = 0
    return ds.assign(depth=(("y", "x"), h), obstacle=(("y", "x"), ob), wet=(("y", "x"), (h > 0).astype("i1")))


@pytest.mark.parametrize("side", ["west", "east", "both"])
@pytest.mark.parametrize("where", ["levee row", "every row"])
@pytest.mark.parametrize("film", [2e-6, 4.9e-5, 1e-3, 0.009])
@pytest.mark.parametrize("offset", [0.0, 0.3, 1.1])
def test_a_film_beside_the_breach_head_is_a_wall(side, where, film, offset):
    """A film of water on the bank beside a breach head (here up to 0.9 % of the channel's 1 m-or-more depth,
    flowing nowhere) does not open the channel's side: the control section is the film-free channel's,
    critical where h = h_c at the speed (g q)^{1/3}. Exactly dry walls only would find no channel here."""
    q, sign = 6.0, 1.0
    hc = (q * q / G) ** (1 / 3)                     # 1.54 m
    y = np.arange(-30.0, 30.1, 2.0) + offset
    h = hc - sign * 0.02 * (y - 3.0)                # h_c at y = 3, 0.92-2.16 m over the channel
    assert film < 0.01 * h.min()
    rows = np.abs(y) == np.abs(y).min() if where == "levee row" else np.ones(y.size, bool)
    ds = with_film(channel(h, sign * q / h, y), rows, side, film)
    yc, vc = control_speed(ds, (-3.0, 3.0), 0.0)
    assert vc == pytest.approx((G * q) ** (1 / 3), rel=0.01)
    assert yc == pytest.approx(3.0, abs=0.1)


@pytest.mark.parametrize("spill", [0.03, 0.2])
def test_water_spilling_round_the_head_is_not_a_wall(spill):
    """Water beside the head at a few per cent of the channel's depth and more is flow round the head, not
    a film: the levee row is not walled, so no channel section is found there."""
    q = 6.0
    y = np.arange(-30.0, 30.1, 2.0)
    h = np.full(y.size, 1.5)
    rows = np.abs(y) < 1.0
    ds = with_film(channel(h, q / h, y), rows, "west", spill * 1.5)
    yc, vc = control_speed(ds, (-3.0, 3.0), 0.0)
    assert np.isnan(yc) and np.isnan(vc)


def test_a_drowned_channel_takes_its_narrowest_flow():
    q = 10.0
    y = np.arange(-10.0, 10.1, 2.0)
    h = 5.0 + 0.1 * np.abs(y - 2.0)          # shallowest (largest Fr < 1) at y = 2
    yc, vc = control_speed(channel(h, q / h, y), (-3.0, 3.0), 0.0)
    assert yc == 2.0 and vc == pytest.approx(q / 5.0)


def run(label, size, seed, *, q=1800.0, vc=6.5, u=7.0):
    return CheckRun(label=label, cell_size=size, seed=seed, closed=True, tonnage=10_000.0, lost_tonnage=0.0,
                    cycles=8, discharge=q, gap_mean_speed=u, gap_max_speed=u + 1, control_speed=vc)


def test_the_check_judges_the_control_speed_and_reports_the_speed_past_it():
    r = judge([run("4 m", 4, 1), run("2 m", 2, 1, q=1810.0, vc=6.52, u=7.5)], 0.02)
    assert r.robust and r.statement.startswith("closed in all 2 runs")
    assert r.flow_difference["gap mean speed"] == pytest.approx(0.5 / 7.0)   # reported
    assert r.flow_difference["control speed"] == pytest.approx(0.02 / 6.5)
    r = judge([run("4 m", 4, 1), run("2 m", 2, 1, vc=6.5 * 1.03, u=7.0)], 0.02)
    assert not r.robust and "control speed +3.0 %" in r.statement
