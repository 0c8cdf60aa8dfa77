"""The porous pile's column in layers (swe/porous.py, cycle/remap.py ``porous_pile``): the layered column
discharge by hand, the layers' solid fractions of a sphere lattice by hand, and the discharge through heaps
of units that changes less with the cell size than with one porosity per column (docs/theory.md,
*Porous flow through the pile*)."""
import math

import numpy as np
import pytest

from breachflow.cycle.remap import PILE_LAYERS, porous_pile
from breachflow.errors import InputError
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.porous import PorousPile, column_discharge, forchheimer_coefficients


def _darcy(S, A, B):
    """Root of ``B V^2 + A V - S = 0`` by the quadratic formula."""
    return (-A + math.sqrt(A * A + 4 * B * S)) / (2 * B)


@pytest.mark.parametrize("h", [0.5, 1.0, 1.5, 2.0, 3.0])
def test_layered_column_discharge_by_hand(h):
    """Two layers of 1 m (porosity 0.3 below, 0.6 above) under a 2 m pile: each layer passes its wetted
    thickness times its own Darcy velocity, the water above the pile flows by Manning."""
    S, n_m, H = 0.01, 0.03, 2.0
    A, B = forchheimer_coefficients(np.array([0.3, 0.6]), 1.0)
    Q, qs = column_discharge(S, h, H, A, B, n_m)
    t1, t2 = min(h, 1.0), min(max(h - 1.0, 0.0), 1.0)
    seep = t1 * _darcy(S, A[0], B[0]) + t2 * _darcy(S, A[1], B[1])
    over = max(h - H, 0.0) ** (5 / 3) * math.sqrt(S) / n_m
    assert qs == pytest.approx(seep, rel=1e-12)
    assert Q == pytest.approx(seep + over, rel=1e-12)


def test_one_layer_is_one_porosity_for_the_column():
    """``K = 1``: the whole column at the column's porosity (a pile given without layers)."""
    A, B = forchheimer_coefficients(0.4, 0.5)
    pile = PorousPile(height=np.array([[1.5]]), porosity=np.array([[0.4]]), diameter=np.array([[0.5]]),
                      A=np.array([[A]]), B=np.array([[B]]))
    assert pile.layer_A.shape == (1, 1, 1) and pile.layer_A[0, 0, 0] == A
    Q, qs = column_discharge(0.02, 3.0, 1.5, pile.layer_A[0, 0], pile.layer_B[0, 0], 0.03)
    assert qs == pytest.approx(1.5 * _darcy(0.02, A, B), rel=1e-12)
    assert Q - qs == pytest.approx(1.5 ** (5 / 3) * math.sqrt(0.02) / 0.03, rel=1e-12)
    with pytest.raises(InputError, match="layer_A"):
        PorousPile(height=np.zeros((2, 2)), porosity=np.ones((2, 2)), diameter=np.ones((2, 2)),
                   A=np.zeros((2, 2)), B=np.zeros((2, 2)), layer_A=np.zeros((2, 3, 4)))


def test_layer_porosity_of_a_sphere_lattice_by_hand():
    """Spheres of radius r = 1 m on a simple cubic lattice (spacing 2 m, one layer) resting on the bed,
    cells of 2 m centred on the spheres, 33 x 33 sub-points (one at each centre: height 2 m). Four layers
    of r / 2: a sphere's cap of height r / 2 holds ``pi (r/2)^2 (3 r - r/2) / 3 = 5 pi r^3 / 24`` of the
    layer's ``4 r^2 r / 2``, solid fraction ``5 pi / 48``; the next layer ``11 pi / 48``; the upper two
    mirror them. One porosity for the column would be ``1 - pi / 6`` in every layer."""
    d = 2.0
    xs = np.arange(0.0, 20.0, d) + d / 2
    pts = np.array([(a, b, d / 2) for a in xs for b in xs])
    x = y = xs
    bed = np.zeros((x.size, x.size))
    pile = porous_pile(x, y, bed, pts, np.full(len(pts), d / 2), np.ones(len(pts), bool), sub=33, layers=4)
    np.testing.assert_allclose(pile.height, d)
    expect = 1 - np.array([5, 11, 11, 5]) * math.pi / 48
    np.testing.assert_allclose(pile.layer_porosity[3:-3, 3:-3], np.broadcast_to(expect, (4, 4, 4)), atol=0.01)
    assert pile.porosity[5, 5] == pytest.approx(1 - math.pi / 6, abs=0.01)  # the layers' mean: the column's
    A, B = forchheimer_coefficients(expect, 1.0 * d)
    np.testing.assert_allclose(pile.layer_B[5, 5], B, rtol=0.05)


def heap(n, seed, x0=18.0, x1=30.0, width=24.0, tries=12):
    """*n* units of 1.9–2.24 m diameter dropped one by one onto a flat floor between ``x0`` and ``x1``
    across the channel: each tries *tries* random spots and stays at the lowest, resting on the floor or on
    the units below (random sequential deposition; no rolling)."""
    rng = np.random.default_rng(seed)
    pos = np.zeros((0, 3))
    rad = np.zeros(0)
    for _ in range(n):
        r = rng.uniform(0.95, 1.12)
        best = None
        for _ in range(tries):
            x, y = rng.uniform(x0, x1), rng.uniform(r, width - r)
            z = r
            if rad.size:
                d2 = (pos[:, 0] - x) ** 2 + (pos[:, 1] - y) ** 2
                m = d2 < (rad + r) ** 2
                if m.any():
                    z = max(z, float(np.max(pos[m, 2] + np.sqrt((rad[m] + r) ** 2 - d2[m]))))
            if best is None or z < best[2]:
                best = (x, y, z)
        pos = np.vstack([pos, best])
        rad = np.append(rad, r)
    return pos, rad


def channel(dx, length=48.0, width=24.0, up=3.0, down=1.5):
    """The channel of the heaps on cells of *dx*: water levels *up* / *down* at its ends, Manning 0.025."""
    dom = uniform_grid(0, length, 0, width, dx, manning=0.025,
                       boundaries={"west": BC("level", level=up), "east": BC("level", level=down)})
    dom.initial_surface = up + (down - up) * (dom.x[None, :] * np.ones(dom.shape)) / length
    return dom


def heap_discharge(pos, rad, dx, layers=PILE_LAYERS, width=24.0, law=None):
    """Steady discharge (m³/s) through the heap in the :func:`channel`, the median over the cross-sections
    upstream of the heap; *law* the pile's flow law."""
    dom = channel(dx, width=width)
    pile = porous_pile(dom.x, dom.y, dom.bed, pos, rad, np.ones(rad.size, bool), layers=layers, law=law)
    sim = SWESimulation(dom.with_porous(pile), SWEOptions(order=2))
    assert sim.run_to_steady(tolerance=1e-5, t_max=900).converged
    q = sim.discharge[0].sum(axis=0) * (width / dom.shape[0])
    return float(np.median(q[(dom.x > 5) & (dom.x < 12)]))


# a heap whose crest the flood overtops (70 units, tops to about 4 m in 3 m of water) and a dam standing
# above the water (150 units); the placement seed swept
HEAPS = [(70, 1), (70, 2), (70, 3), (150, 1), (150, 2), (150, 3)]


@pytest.mark.parametrize("n,seed", HEAPS)
def test_heap_discharge_changes_less_with_the_cells_in_layers(n, seed):
    """The closure's grids (4 m and 2 m cells) with units of about 2 m: one porosity for the column took
    the open water between the crowns for pores and passed 13-23 % more on 4 m cells than on 2 m cells
    (measured, ``python tests/swe/test_porous_layers.py``); the layered column (the default) differs by at
    most 15 % and by less than 0.7 times the single column's difference for every heap."""
    pos, rad = heap(n, seed)
    q = {(layers, dx): heap_discharge(pos, rad, dx, layers) for layers in (1, PILE_LAYERS) for dx in (4.0, 2.0)}
    single = abs(q[1, 4.0] / q[1, 2.0] - 1)
    layered = abs(q[PILE_LAYERS, 4.0] / q[PILE_LAYERS, 2.0] - 1)
    assert layered < 0.15, q
    assert layered < 0.7 * single, q


@pytest.mark.slow
@pytest.mark.parametrize("n,seed", HEAPS)
def test_heap_discharge_on_2_and_1_m_cells(n, seed):
    """Halving the cells again (2 m -> 1 m, a unit two cells wide): the layered column within 8 % (the
    single column: 6-17 %)."""
    pos, rad = heap(n, seed)
    q2, q1 = (heap_discharge(pos, rad, dx, PILE_LAYERS) for dx in (2.0, 1.0))
    assert abs(q2 / q1 - 1) < 0.08, (q2, q1)


if __name__ == "__main__":  # the table of the docs: discharge per heap, column model and cell size
    # (arguments: cell sizes "4,2,1", heaps "units:seed,..." e.g. "25:1" for a sparse scatter, flow laws
    # "ergun,ergun_dilute" — given, the layered column only)
    import sys

    grids = [float(v) for v in (sys.argv[1].split(",") if len(sys.argv) > 1 else ("4", "2", "1"))]
    heaps = [tuple(int(v) for v in h.split(":")) for h in sys.argv[2].split(",")] if len(sys.argv) > 2 else HEAPS
    laws = sys.argv[3].split(",") if len(sys.argv) > 3 else [None]
    models = [(1, None), (PILE_LAYERS, None)] if len(sys.argv) <= 3 else [(PILE_LAYERS, law) for law in laws]
    print("units seed layers law          " + " ".join(f"{g:>8g} m" for g in grids))
    for n, seed in heaps:
        pos, rad = heap(n, seed)
        for layers, law in models:
            qs = [heap_discharge(pos, rad, g, layers, law=law) for g in grids]
            print(f"{n:5d} {seed:4d} {layers:6d} {law or 'default':12s} " + " ".join(f"{v:10.2f}" for v in qs),
                  flush=True)
        median = []
        for g in grids:
            dom = channel(g)
            pile = porous_pile(dom.x, dom.y, dom.bed, pos, rad, np.ones(rad.size, bool))
            median.append(np.median(pile.layer_porosity[pile.height > 0]))
        print(f"{n:5d} {seed:4d} median layer porosity " + " ".join(f"{v:10.2f}" for v in median))
