"""Flow laws of the porous pile (swe/porous_laws.py): the registry, Ergun's and van Gent's coefficients by
hand, and ``ergun_dilute`` against its two limits — Ergun in a packed pile, a lone stone's drag and
Richardson & Zaki's suspension in a sparse one — and against the cell size around a scatter of units
(docs/theory.md, *Porous flow through the pile*)."""
import math

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.errors import InputError, ParseError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with
from breachflow.swe.porous import PorousPile, forchheimer_coefficients
from breachflow.swe.porous_laws import POROUS_LAWS, ErgunDiluteLaw, ForchheimerLaw, VanGentLaw, porous_law

from .test_porous_layers import heap, heap_discharge

G = 9.81
RHO = 1000.0


def test_the_registry_names_the_laws_and_refuses_unknown_ones():
    assert POROUS_LAWS.default == "ergun"
    assert {"ergun", "van_gent", "ergun_dilute"} <= set(POROUS_LAWS.available())
    assert porous_law() == ForchheimerLaw(150.0, 1.75)
    assert porous_law("van_gent") == VanGentLaw()
    assert VanGentLaw().coefficients(0.4, 1.0) == ForchheimerLaw(1000.0, 1.1).coefficients(0.4, 1.0)
    law = ErgunDiluteLaw(drag_coefficient=0.5)
    assert porous_law(law) is law
    with pytest.raises(InputError, match="darcy.*ergun"):
        porous_law("darcy")
    with pytest.raises(InputError, match="porosity"):
        porous_law("ergun_dilute").coefficients(1.0, 1.0)
    # a pile built with a law by name carries that law's coefficients in every layer
    pile = PorousPile.build([[2.0]], [[0.6]], [[1.5]], law="ergun_dilute", layer_porosity=[[[0.35, 0.7]]])
    expect = ErgunDiluteLaw().coefficients(np.array([0.35, 0.7]), 1.5)
    np.testing.assert_allclose(pile.layer_B[0, 0], expect[1], rtol=1e-14)
    np.testing.assert_allclose(pile.layer_A[0, 0], expect[0], rtol=1e-14)


@pytest.mark.parametrize("n,d", [(0.35, 0.2), (0.45, 1.0), (0.7, 2.0)])
def test_forchheimer_laws_by_hand(n, d):
    """``A = alpha nu (1-n)^2 / (g n^3 d^2)``, ``B = beta (1-n) / (g n^3 d)`` with Ergun's 150 / 1.75 and van
    Gent's 1000 / 1.1."""
    nu = 1.0e-6
    for name, alpha, beta in (("ergun", 150.0, 1.75), ("van_gent", 1000.0, 1.1)):
        A, B = forchheimer_coefficients(n, d, name)
        assert A == pytest.approx(alpha * nu * (1 - n) ** 2 / (G * n ** 3 * d ** 2), rel=1e-12)
        assert B == pytest.approx(beta * (1 - n) / (G * n ** 3 * d), rel=1e-12)


def test_dilute_law_is_ergun_in_a_packed_pile_and_continuous():
    """Below the crossover porosity ``(3 C_D / 7)^(1 / (2 m - 3))`` = 0.392 (C_D 0.44, m 2.39) the law is
    Ergun's exactly; the two branches meet there (no jump), and above it the law resists less."""
    law = ErgunDiluteLaw()
    nc = law.crossover_porosity()
    assert nc == pytest.approx((3 * 0.44 / 7) ** (1 / (2 * 2.39 - 3)), rel=1e-12)
    assert 0.38 < nc < 0.40  # a packed pile's porosity
    n = np.linspace(0.2, 0.99, 400)
    A, B = law.coefficients(n, 1.2)
    Ae, Be = ForchheimerLaw().coefficients(n, 1.2)
    np.testing.assert_array_equal(A, Ae)
    packed = n <= nc
    np.testing.assert_array_equal(B[packed], Be[packed])
    assert np.all(B[~packed] < Be[~packed])
    below, above = law.coefficients(np.array([nc - 1e-9, nc + 1e-9]), 1.2)[1]
    assert above == pytest.approx(below, rel=1e-6)
    assert np.all(np.diff(B) < 0)  # more open, less resistance


@pytest.mark.parametrize("d", [0.5, 2.0])
def test_a_lone_stone_resists_by_its_own_drag(d):
    """A few spheres far apart in a volume of water (porosity 0.9995): the gradient ``I`` times ``rho g`` and
    the volume is the sum of the spheres' drags ``C_D rho (pi d^2 / 4) V^2 / 2`` (C_D 0.44), within the
    hindrance ``n^(-2 m)`` = 1.0025. Ergun's gradient there is 5.3 times as large."""
    volume, spheres, V = 10000.0 * d ** 3, 10, 1.5
    n = 1 - spheres * math.pi * d ** 3 / 6 / volume
    _, B = ErgunDiluteLaw().coefficients(n, d)
    drag = spheres * 0.5 * 0.44 * RHO * math.pi * d ** 2 / 4 * V ** 2
    assert RHO * G * B * V ** 2 * volume == pytest.approx(drag, rel=0.003)
    _, Be = ForchheimerLaw().coefficients(n, d)
    assert Be / B == pytest.approx(1.75 / (0.75 * 0.44), rel=0.01)


@pytest.mark.parametrize("n", [0.45, 0.6, 0.8, 0.95])
def test_dilute_law_holds_a_suspension_at_richardson_zakis_velocity(n):
    """A suspension of spheres (density 2,650 kg/m³, 1 m) in an upflow of superficial velocity
    ``V = U_t n^2.39`` (Richardson & Zaki 1954, Newton regime; ``U_t`` the lone sphere's settling velocity
    with C_D 0.44) stays at rest: the flow's gradient carries the spheres' submerged weight,
    ``rho g I = (1 - n) (rho_s - rho) g``."""
    d, rho_s = 1.0, 2650.0
    u_t = math.sqrt(4 * G * d * (rho_s / RHO - 1) / (3 * 0.44))
    V = u_t * n ** 2.39
    _, B = ErgunDiluteLaw().coefficients(n, d)
    assert RHO * G * B * V ** 2 == pytest.approx((1 - n) * (rho_s - RHO) * G, rel=1e-9)


SCENE = (__import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def test_a_scenario_chooses_the_law_by_name_and_a_bad_name_is_named():
    assert closure_setup(parse_scenario(SCENE)).porous_law == "ergun"
    setup = closure_setup(parse_scenario(scenario_with(SCENE, {"closure.porous_law": "ergun_dilute"})))
    assert setup.porous_law == "ergun_dilute"
    with pytest.raises(ParseError, match=r"\[closure\] porous_law: 'darcy' unknown.*ergun_dilute"):
        parse_scenario(scenario_with(SCENE, {"closure.porous_law": "darcy"}))


# scatters of units on the channel floor, the placement seed swept
SPARSE = [(25, 1), (25, 2), (25, 3)]


@pytest.mark.parametrize("n,seed", SPARSE)
def test_a_scatter_of_units_passes_the_same_on_4_and_2_m_cells(n, seed):
    """A scatter of 25 units of about 2 m (some 30 % of the floor): with Ergun's law a lone unit made its
    whole 4 m cell a column resisting five times its drag, and 4 m cells passed 7.6-9.5 % less than 2 m
    cells (measured, ``python tests/swe/test_porous_layers.py 4,2,1 25:1,25:2 ergun,ergun_dilute``);
    with the stones' own drag in sparse cells within 3 %, and closer than with Ergun."""
    pos, rad = heap(n, seed)
    q = {(law, dx): heap_discharge(pos, rad, dx, law=law) for law in ("ergun", "ergun_dilute") for dx in (4.0, 2.0)}
    ergun = abs(q["ergun", 4.0] / q["ergun", 2.0] - 1)
    dilute = abs(q["ergun_dilute", 4.0] / q["ergun_dilute", 2.0] - 1)
    assert dilute < 0.03, q
    assert dilute < 0.5 * ergun, q


@pytest.mark.slow
@pytest.mark.parametrize("n,seed", SPARSE)
def test_a_scatter_of_units_on_2_and_1_m_cells(n, seed):
    """Halving the cells again: within 3 % (Ergun's law: 6.7-8.7 % more on 1 m cells)."""
    pos, rad = heap(n, seed)
    q2, q1 = (heap_discharge(pos, rad, dx, law="ergun_dilute") for dx in (2.0, 1.0))
    assert abs(q2 / q1 - 1) < 0.03, (q2, q1)
