"""The seal in the flow model (breachflow.cycle.sealing): the layered Forchheimer coefficients of the sealed
pile cells, the SWE's leakage through a sealed strip against an independent 1-D integration, the seal's
delivery time, and the refusal of a seal that breaks the filter rules."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from breachflow.cycle.delivery import delivery_method
from breachflow.cycle.sealing import seal_delivery, seal_pile
from breachflow.errors import InputError
from breachflow.materials.seal import Grading
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.porous import PorousPile

G, NU = 9.81, 1.0e-6


def _ergun(n, d):
    """Ergun's A, B written out here (150 and 1.75; Ergun 1952), independent of the package's function."""
    return 150 * NU * (1 - n) ** 2 / (G * n ** 3 * d ** 2), 1.75 * (1 - n) / (G * n ** 3 * d)


def _strip(h1=3.0, h2=2.0, L=20.0, dy=0.25, width=0.5, rock=0.5, n=0.4, reach=5.0):
    """A frictionless channel along y (walls at the sides), levels h1 at y = 0 and h2 at the far end, a
    rock pile of stones *rock* (m), above the water, from y = *reach* over *L* (open water either side)."""
    total = L + 2 * reach
    dom = uniform_grid(0, width, 0, total, dy, manning=0.0,
                       boundaries={"south": BC("level", level=h1), "north": BC("level", level=h2)})
    yy = dom.y[:, None] * np.ones(dom.shape)
    dom.initial_surface = np.clip(h1 + (h2 - h1) * (yy - reach) / L, h2, h1)
    inside = (yy > reach) & (yy < reach + L)
    pile = PorousPile.build(np.where(inside, 10.0, 0.0), np.full(dom.shape, n), np.full(dom.shape, rock))
    return dom, pile


def _q_1d(h1, h2, L, layers):
    """Unit discharge of 1-D steady Dupuit–Forchheimer flow through layers ``[(length, A, B)]`` in series
    (``dh/dy = -(A q/h + B q^2/h^2)``, integrated layer by layer with scipy, shot on q to reach h2)."""
    def end_depth(q):
        h = h1
        for length, A, B in layers:
            sol = solve_ivp(lambda _y, hh: -(A * q / hh + B * q * q / hh ** 2), (0, length), [h], rtol=1e-10,
                            atol=1e-12)
            h = float(sol.y[0, -1])
            if not sol.success or h <= 0.05:
                return -1.0
        return h - h2
    return brentq(end_depth, 1e-7, 5.0, xtol=1e-12)


def test_sealed_cells_take_the_layers_in_series_by_length():
    """Per cell, ``A = (l_rock A_rock + Σ l_k A_k) / Δy``: the layer boundaries fall inside cells (1.1 m seal and
    0.3 m filter on 0.5 m cells), the face is the first pile cell's edge, from either side; tonnage = length × Δx
    × height × (1 - n) rho."""
    y = (np.arange(10) + 0.5) * 0.5          # cells of 0.5 m, pile in cells 2..7 (y 1.0–4.0)
    height = np.zeros((10, 3))
    height[2:8] = 2.0
    pile = PorousPile.build(height, np.full(height.shape, 0.4), np.full(height.shape, 0.5))
    seal = Grading("s", 0.001, 0.002, 0.004, porosity=0.3, density=2000.0)
    filt = Grading("f", 0.01, 0.02, 0.04, porosity=0.35)
    As, Bs = _ergun(0.3, 0.002)
    Af, Bf = _ergun(0.35, 0.02)
    Ar = float(pile.A[2, 0])
    for side, order in ((-1, [2, 3, 4]), (1, [7, 6, 5])):
        sealed, tons = seal_pile(pile, y, [(seal, 1.1), (filt, 0.3)], side, dx=1.0)
        # seal: 0.5 + 0.5 + 0.1 m; filter 0.3 m in the third cell; rock 0.1 m there
        a0, a1, a2 = order
        assert sealed.A[a0, 1] == pytest.approx(As, rel=1e-12)
        assert sealed.A[a1, 1] == pytest.approx(As, rel=1e-12)
        assert sealed.A[a2, 1] == pytest.approx((0.1 * As + 0.3 * Af + 0.1 * Ar) / 0.5, rel=1e-12)
        assert sealed.B[a2, 1] == pytest.approx((0.1 * Bs + 0.3 * Bf + 0.1 * float(pile.B[2, 0])) / 0.5, rel=1e-12)
        untouched = [j for j in range(2, 8) if j not in order]
        np.testing.assert_array_equal(sealed.A[untouched], pile.A[untouched])
        assert tons["s"] == pytest.approx(3 * 1.1 * 1.0 * 2.0 * 0.7 * 2000.0 / 1e3)
        assert tons["f"] == pytest.approx(3 * 0.3 * 1.0 * 2.0 * 0.65 * 2650.0 / 1e3)


@pytest.mark.parametrize("thickness", [2.0, 1.9])
def test_swe_leakage_through_a_sealed_strip_matches_1d_layers_in_series(thickness):
    """A 20 m rock strip (0.5 m stones) with a seal of 2 m (on cell edges) or 1.9 m (ending inside a cell) of
    5 cm gravel on its upstream face, 3 m -> 2 m: the SWE's steady discharge equals the 1-D integration of
    the two layers in series within 1.5 %, and the seal cuts the leakage by more than half."""
    h1, h2, L = 3.0, 2.0, 20.0
    dom, pile = _strip(h1, h2, L)
    gravel = Grading("gravel", 0.04, 0.05, 0.06, porosity=0.4)
    sealed, _ = seal_pile(pile, dom.y, [(gravel, thickness)], side=-1, x=dom.x)
    sim = SWESimulation(dom.with_porous(sealed), SWEOptions(order=2))
    assert sim.run_to_steady(tolerance=1e-6, t_max=4000).converged
    q_swe = float(np.median(sim.discharge[1][4:-4]))
    As, Bs = _ergun(0.4, 0.05)
    Ar, Br = _ergun(0.4, 0.5)
    q_1d = _q_1d(h1, h2, L, [(thickness, As, Bs), (L - thickness, Ar, Br)])
    q_rock = _q_1d(h1, h2, L, [(L, Ar, Br)])
    assert q_1d < 0.5 * q_rock
    assert q_swe == pytest.approx(q_1d, rel=0.015), (q_swe, q_1d, q_rock)


def test_seal_delivery_time_is_tonnes_over_capacity_within_working_hours():
    """4,000 t at 400 t/h: 10 h of work; round the clock it ends 10 h after the start, with 8 working hours a
    day (from the start) it ends at 24 h + 2 h."""
    m = delivery_method("barge_crane", capacity=400.0 * 1000 / 3600)
    work, end = seal_delivery(4000.0, m, start=5 * 3600.0)
    assert work == pytest.approx(10 * 3600.0)
    assert end == pytest.approx(15 * 3600.0)
    m8 = delivery_method("barge_crane", capacity=400.0 * 1000 / 3600, working_hours=8 * 3600.0)
    work, end = seal_delivery(4000.0, m8, start=5 * 3600.0)
    assert work == pytest.approx(10 * 3600.0)
    assert end == pytest.approx(5 * 3600.0 + 24 * 3600.0 + 2 * 3600.0, abs=60.0)


def test_seal_that_breaks_the_filter_rules_is_refused_naming_layers_and_rule():
    from breachflow.cycle.leakage import PolderLeakage

    c = PolderLeakage("1 cm/day", area="100 ha", seal=["sand", "quarry_run"])
    rock = Grading("rock dam", 1.5, 1.7, 1.8)
    with pytest.raises(InputError, match=r"sand would wash out through quarry_run: D15_quarry_run/D85_sand"):
        c.bind_rock(rock)
    c = PolderLeakage("1 cm/day", area="100 ha", seal=["sand", "gravel", "quarry_run", "LMA_40_200"])
    c.bind_rock(rock)  # sand 0.6 mm -> gravel 2.5 mm -> quarry run 4 cm -> LMA 40-200 kg -> 1.5 m: every rule holds
    c = PolderLeakage("1 cm/day", area="100 ha", seal=["sand", "gravel", "quarry_run", "LMA_60_300"])
    with pytest.raises(InputError, match=r"rock dam does not drain LMA_60_300.*< 5"):
        c.bind_rock(rock)
