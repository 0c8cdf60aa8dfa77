"""Quiet cells (water at rest, dry land) skip the flux work without changing the solution (issue 16)."""
import numpy as np
import pytest

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe import kernels as K
from breachflow.swe.step import activity, primitives
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid


def _ranges(sim, tol=1e-14):
    """Activity ranges of every padded row of *sim*'s current state (a full check)."""
    nyp, nxp = sim.h.shape
    u, v, eta = (np.zeros_like(sim.h) for _ in range(3))
    primitives(sim.h, sim.hu, sim.hv, sim.z, sim.obst, u, v, eta, 1e-8, sim.dx, sim.dy, 9.81, False, np.zeros(nyp))
    lo = np.full(nyp, nxp, np.int64)
    hi = np.full(nyp, -1, np.int64)
    activity(sim.h, sim.hu, sim.hv, eta, sim.obst, lo, hi, lo.copy(), hi.copy(), True, True, tol, 9.81)
    return lo, hi


def test_a_single_moving_cell_wakes_exactly_its_cross_stencil():
    """In a lake at rest (its surface h + z equal to round-off) the cells whose update can be non-zero are
    those with the moving cell within two cells along x or y (the reach of a second-order face flux): row
    j0 from i0-2 to i0+2, column i0 from j0-2 to j0+2; every other row is quiet."""
    dom = uniform_grid(0, 20, 0, 12, 1.0, bed=lambda X, Y: 0.1 * np.sin(X) * np.cos(Y), initial_surface=1.0)
    sim = SWESimulation(dom)
    lo, hi = _ranges(sim)
    assert (lo > hi).all()  # all at rest
    j0, i0 = K.G + 5, K.G + 9
    sim.hu[j0, i0] = 1e-3
    lo, hi = _ranges(sim)
    for j in range(sim.h.shape[0]):
        if j == j0:
            assert (lo[j], hi[j]) == (i0 - 2, i0 + 2)
        elif abs(j - j0) <= 2:
            assert (lo[j], hi[j]) == (i0, i0)
        else:
            assert lo[j] > hi[j], j
    # a surface step (no flow yet) wakes the cells that see it, dry land stays quiet
    sim.hu[j0, i0] = 0.0
    sim.h[j0, i0] += 1e-6
    lo, hi = _ranges(sim)
    assert (lo[j0], hi[j0]) == (i0 - 2, i0 + 2)


def _beach():
    """A basin at rest (level 1 m) whose east half is a dry beach rising to 2 m, walls all round, with a
    0.6 m hump of water released at the west end: the wave runs up the dry beach."""
    bed = lambda X, Y: np.where(X > 20.0, 0.08 * (X - 20.0), 0.0) + 0.05 * np.cos(Y / 3.0)  # noqa: E731
    surface = lambda X, Y: np.where(X < 6.0, 1.6, 1.0)  # noqa: E731
    walls = {side: [BC.wall()] for side in ("west", "east", "south", "north")}
    return uniform_grid(0, 60, 0, 20, 0.5, bed=bed, initial_surface=surface, boundaries=walls, manning=0.02)


@pytest.mark.parametrize("order", [1, 2])
def test_skipping_quiet_cells_is_exact_on_a_wetting_front(order):
    """With tolerance 0 the skipped updates are exactly zero: depth, discharge, wet/dry front and step
    count are bitwise those of the full computation, mass is conserved to round-off, and the dry beach
    did cost no flux work while it was dry."""
    dom = _beach()
    runs = {}
    for skip in (False, True):
        sim = SWESimulation(dom, SWEOptions(order=order, skip_quiet=skip, quiet_tolerance=0.0))
        v0 = sim.volume()
        sim.advance_to(8.0)
        runs[skip] = sim
        assert abs(sim.volume() - v0) <= 1e-12 * v0
    full, skipped = runs[False], runs[True]
    assert full.steps == skipped.steps
    for a, b in ((full.h, skipped.h), (full.hu, skipped.hu), (full.hv, skipped.hv)):
        assert np.array_equal(a, b)
    wet = skipped.depth > 0
    assert wet.any() and (~wet).any()  # the front is inside the domain
    assert (dom.bed[~wet] > 1.0).all()  # what stayed dry is beach above the lake
    stages = full.stats[3]
    assert stages == full.steps * order * dom.bed.size  # without skipping every cell works
    assert skipped.stats[3] < 0.85 * stages


def test_the_default_tolerance_changes_the_solution_by_round_off_only():
    """The default tolerance (1e-14 of the depth) skips the exponentially small precursor ahead of a
    wave too: depths differ from the full computation by round-off, mass and the wet area are the same."""
    dom = _beach()
    full = SWESimulation(dom, SWEOptions(skip_quiet=False)).advance_to(8.0)
    sim = SWESimulation(dom, SWEOptions())
    v0 = sim.volume()
    sim.advance_to(8.0)
    assert sim.steps == full.steps
    assert np.abs(sim.depth - full.depth).max() <= 1e-12
    assert np.abs(sim.discharge[0] - full.discharge[0]).max() <= 1e-12
    assert abs(sim.volume() - v0) <= 1e-12 * v0
    assert np.array_equal(sim.depth > 1e-8, full.depth > 1e-8)
    assert sim.stats[3] < full.stats[3]


def test_two_threads_give_the_same_solution_as_one():
    """Blocks of rows in parallel recompute the face rows between blocks: the same numbers."""
    dom = uniform_grid(0, 30, 0, 17, 0.5, manning=0.03, bed=lambda X, Y: 0.2 * np.sin(X / 3.0) * np.cos(Y / 2.0),
                       initial_surface=lambda X, Y: np.where(X + 0.5 * Y < 12.0, 1.5, 0.0))
    one = SWESimulation(dom, SWEOptions(threads=1)).advance_to(3.0)
    two = SWESimulation(dom, SWEOptions(threads=2)).advance_to(3.0)
    assert one.steps == two.steps
    assert np.array_equal(one.h, two.h) and np.array_equal(one.hu, two.hu) and np.array_equal(one.hv, two.hv)


def test_quiet_tolerance_out_of_range_is_an_input_error():
    from breachflow.errors import InputError

    with pytest.raises(InputError, match="quiet_tolerance"):
        SWEOptions(quiet_tolerance=-1.0)


@pytest.mark.parametrize("order", [1, 2])
def test_skipping_is_exact_next_to_interior_obstacles(order):
    """A dam break in a basin with a wall of obstacle cells across it, open in a 3-cell gap: the flow hits
    the wall and runs through the gap while the far end is still at rest. Faces between a working cell and
    an obstacle are walls (they reflect momentum) even where the obstacle lies outside the working range:
    skipping with tolerance 0 is bitwise the full computation."""
    dom = uniform_grid(0, 40, 0, 20, 0.5, manning=0.02, initial_surface=lambda X, Y: np.where(X < 8.0, 1.5, 1.0))
    X, Y = np.meshgrid(dom.x, dom.y)
    wall = (np.abs(X - 15.0) < 1.0) & ~(np.abs(Y - 7.0) < 0.8)
    dom = dom.with_obstacles(wall)
    runs = {}
    for skip in (False, True):
        sim = SWESimulation(dom, SWEOptions(order=order, skip_quiet=skip, quiet_tolerance=0.0))
        sim.advance_to(4.0)
        runs[skip] = sim
    full, skipped = runs[False], runs[True]
    assert np.abs(full.discharge[0][~wall]).max() > 0.1  # the wave reached the wall and the gap
    assert skipped.stats[3] < full.stats[3]  # and something was skipped
    assert full.steps == skipped.steps
    for a, b in ((full.h, skipped.h), (full.hu, skipped.hu), (full.hv, skipped.hv)):
        assert np.array_equal(a, b)
