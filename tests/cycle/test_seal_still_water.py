"""A seal that closes every path from the flood to the polder: the flow model's steady state is water at rest
at the two levels, the leakage the seepage by layers in series under that head, read without a re-solve; a
seal that leaves a path open is re-solved."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.leakage import PolderLeakage
from breachflow.cycle.sealing import (face_cells, flood_connected, seal_dam, seal_pile, separates, series_leakage,
                                      still_water)
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.porous import PorousPile

FLOOD, TAIL = 4.0, 1.5
NY, NX = 14, 4
BREACH = (1.0, 3.0)       # columns 1 and 2 (cells of 1 m), levee body in columns 0 and 3
PILE_ROWS = slice(5, 9)   # the pile 4 m long, crest 6 m above the bed at 0 m


def _scene(gap: bool = False, flip: bool = False):
    """The channel of 1 m cells along y, the flood at low y (*flip*: mirrored north-south, the flood at high y;
    the pile's rows 5-8 are symmetric about the levee line at y = 7 m)."""
    x = np.arange(NX) + 0.5
    y = np.arange(NY) + 0.5
    levee = np.zeros((NY, NX), bool)
    levee[PILE_ROWS, 0] = levee[PILE_ROWS, 3] = True
    height = np.zeros((NY, NX))
    height[PILE_ROWS, 1] = 6.0
    height[PILE_ROWS, 2] = 0.0 if gap else 6.0
    pile = PorousPile.build(height, np.full(height.shape, 0.4), np.full(height.shape, 1.0))
    depth = np.where(y[:, None] < 7, FLOOD, TAIL) * np.ones((NY, NX))
    if flip:
        height, depth = height[::-1], depth[::-1]
        pile = PorousPile.build(height, np.full(height.shape, 0.4), np.full(height.shape, 1.0))
    snap = xr.Dataset({"depth": (("y", "x"), depth), "water_surface": (("y", "x"), depth),
                       "u": (("y", "x"), np.zeros((NY, NX))),
                       "v": (("y", "x"), np.full((NY, NX), -0.1 if flip else 0.1)),
                       "obstacle": (("y", "x"), levee.astype("i1"))}, coords={"x": x, "y": y})
    return x, y, levee, pile, snap


def _criterion():
    c = PolderLeakage("1 cm/day", area="1 ha", seal=["sand", "gravel", "quarry_run", "LMA_40_200"],
                      max_seal_thickness="0.5 m")
    return c


def _reach(bed, barrier, side=-1):
    return flood_connected((bed < FLOOD) & ~barrier, side)


def test_a_seal_over_every_gap_column_separates_the_sides_and_a_gap_does_not():
    x, _y, levee, pile, _ = _scene()
    bed = np.zeros((NY, NX))
    block = face_cells(pile, -1, BREACH, x, FLOOD, bed, levee)
    assert block[5, 1] and block[5, 2] and block.sum() == 2
    assert separates(pile, _reach(bed, levee | block), -1)
    assert not separates(pile, _reach(bed, levee), -1)  # the face left open: water seeps through the pile
    x, _y, levee, pile, _ = _scene(gap=True)
    block = face_cells(pile, -1, BREACH, x, FLOOD, bed, levee)
    assert not separates(pile, _reach(bed, levee | block), -1)  # column 2 has no rock: the flood runs through


@pytest.mark.parametrize("flip", [False, True])
def test_still_water_leakage_is_the_series_seepage_under_flood_minus_polder_without_a_re_solve(flip):
    """Per sealed column ``q = h 2H / (A + sqrt(A^2 + 4 B H))`` with ``H`` = flood - polder level (4 - 1.5 m) and
    ``h`` the flood depth (4 m), ``A = Σ L a``, ``B = Σ L b`` over 0.5 m sand, three 0.5 m filters and 2 m of rock;
    the same with the flood on the other side of the grid."""
    x, y, levee, pile, snap = _scene(flip=flip)
    crit = _criterion()

    def solve(*_a):
        raise AssertionError("a seal that separates the two sides needs no re-solve")

    res = seal_dam(solve, pile, snap, crit, breach_x=BREACH, levee_y=7.0, y=y, x=x, thickness0=0.5,
                   flood_level=FLOOD, bed=np.zeros((NY, NX)), obstacle=levee, tailwater=TAIL)
    step = res.last
    assert step.reading == "still water" and step.steady and step.flow_model_leakage == 0.0
    layers = [(0.5, *g.forchheimer("ergun")) for g in crit.seal_layers]
    a_r, b_r = float(pile.A[6, 1]), float(pile.B[6, 1])
    A = sum(L * a for L, a, _ in layers) + 2.0 * a_r
    B = sum(L * b for L, _, b in layers) + 2.0 * b_r
    H, h = FLOOD - TAIL, FLOOD
    expected = 2 * 1.0 * h * 2 * H / (A + np.sqrt(A * A + 4 * B * H))  # two columns of 1 m
    assert step.leakage == pytest.approx(expected, rel=1e-12)
    up, down = (-1, 1) if flip else (0, 12)
    assert float(res.snapshot["water_surface"][up, 1]) == FLOOD and float(res.snapshot["depth"][down, 1]) == TAIL
    assert float(np.abs(res.snapshot["u"]).max()) == 0.0 and res.snapshot.attrs["steady_state"] == 1


def test_a_dry_polder_gives_the_full_flood_depth_as_head():
    x, y, levee, pile, snap = _scene()
    bed = np.zeros((NY, NX))
    block = face_cells(pile, -1, BREACH, x, FLOOD, bed, levee)
    still = still_water(snap, bed, _reach(bed, levee | block), FLOOD, None)
    assert float(still["depth"][12, 1]) == 0.0 and float(still["depth"][2, 1]) == FLOOD
    assert float(still["depth"][6, 1]) == 0.0  # the pile behind the sealed face drains to the polder side


def test_the_flow_model_converges_to_water_at_rest_behind_a_separating_seal():
    """The model's own steady state: the channel with the levels FLOOD and TAIL at its ends, the sealed face
    closed, marched 1,500 s from a flowing start (0.3 m below and 0.4 m above the two levels): it comes to rest
    (speeds of round-off) at the two levels, and the series seepage read from it equals the still-water reading
    (the claim that lets the seal stage skip the re-solve)."""
    x, y, levee, pile, snap = _scene()
    bed = np.zeros((NY, NX))
    block = face_cells(pile, -1, BREACH, x, FLOOD, bed, levee)
    crit = _criterion()
    layers = [(crit.seal_layers[0], 0.5)] + [(g, 0.5) for g in crit.seal_layers[1:]]
    sealed, _ = seal_pile(pile, y, layers, -1, x=x, x_range=BREACH)
    dom = uniform_grid(0, NX, 0, NY, 1.0, manning=0.02,
                       boundaries={"south": BC("level", level=FLOOD), "north": BC("level", level=TAIL)})
    dom.initial_surface = np.where(y[:, None] < 7, FLOOD - 0.3, TAIL + 0.4) * np.ones((NY, NX))
    sim = SWESimulation(dom.with_porous(sealed), SWEOptions(order=2), obstacles=levee | block)
    sim.advance_to(1500.0)
    model = sim.snapshot()
    still = still_water(snap, bed, _reach(bed, levee | block), FLOOD, TAIL)
    q_model = series_leakage(model, pile, layers, -1, BREACH, columns=block.any(axis=0))
    q_still = series_leakage(still, pile, layers, -1, BREACH, columns=block.any(axis=0))
    assert q_model == pytest.approx(q_still, rel=1e-9)
    assert float(np.abs(model["v"].values).max()) < 1e-9
    np.testing.assert_allclose(model["water_surface"].values[:5, 1:3], FLOOD, atol=1e-9)
    np.testing.assert_allclose(model["water_surface"].values[9:, 1:3], TAIL, atol=1e-9)
