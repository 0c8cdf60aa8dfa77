"""Remapping resting spheres to obstacles / raised bed, and the seeded placement plan."""
import numpy as np
import pytest

from breachflow import InputError
from breachflow.cycle.placement import PlacementPlan
from breachflow.cycle.remap import remap


def grid(n=41, h=0.25):
    x = (np.arange(n) - n // 2) * h
    return x, x.copy()


def test_no_flow_footprint_is_the_disc_of_cell_centres():
    x, y = grid()
    bed = np.zeros((y.size, x.size))
    pos = np.array([[0.1, -0.2, 0.5], [3.0, 3.0, 0.5]])
    r = np.array([1.0, 1.0])
    obst, newbed = remap(x, y, bed, bed + 2.0, pos, r, np.array([True, False]))
    X, Y = np.meshgrid(x, y)
    np.testing.assert_array_equal(obst, (X - 0.1) ** 2 + (Y + 0.2) ** 2 <= 1.0)
    np.testing.assert_array_equal(newbed, bed)


def test_raised_bed_is_the_sphere_top_and_emergent_cells_block():
    x, y = grid()
    bed = np.zeros((y.size, x.size))
    pos = np.array([[0.0, 0.0, 0.2]])
    r = np.array([1.0])
    obst, newbed = remap(x, y, bed, np.full(bed.shape, 1.0), pos, r, np.array([True]), mode="raised_bed")
    X, Y = np.meshgrid(x, y)
    d2 = X**2 + Y**2
    top = np.where(d2 <= 1.0, 0.2 + np.sqrt(np.clip(1.0 - d2, 0, None)), -np.inf)
    np.testing.assert_allclose(newbed, np.where(top > 0, top, 0.0))
    np.testing.assert_array_equal(obst, top >= 1.0)  # emergent where the top reaches the surface (1 m)
    assert obst.any() and (newbed > 0).sum() > obst.sum()
    with pytest.raises(InputError, match="remap mode"):
        remap(x, y, bed, bed, pos, r, np.array([True]), mode="sandbags")


def _cell_fraction(x, y, inside, k=64):
    """Per cell: the area fraction where *inside(X, Y)* holds, by a k × k midpoint raster (a reference
    independent of the remap's sub-points)."""
    h = x[1] - x[0]
    o = ((np.arange(k) + 0.5) / k - 0.5) * h
    X = x[None, :, None, None] + o[None, None, None, :]
    Y = y[:, None, None, None] + o[None, None, :, None]
    return inside(X, Y).mean(axis=(2, 3))


def test_cell_average_no_flow_blocks_the_cells_the_footprint_covers_at_least_half():
    x, y = grid()
    bed = np.zeros((y.size, x.size))
    pos = np.array([[0.1, -0.2, 0.5], [3.0, 3.0, 0.5]])
    r = np.array([1.0, 1.0])
    obst, newbed = remap(x, y, bed, bed + 2.0, pos, r, np.array([True, False]), sampling="cell_average")
    frac = _cell_fraction(x, y, lambda X, Y: (X - 0.1) ** 2 + (Y + 0.2) ** 2 < 1.0)
    sure = np.abs(frac - 0.5) > 0.05  # the sub-point estimate of the fraction decides the others
    np.testing.assert_array_equal(obst[sure], frac[sure] >= 0.5)
    assert obst.sum() == pytest.approx(np.pi / 0.25**2, rel=0.05)  # the disc's area in cells
    np.testing.assert_array_equal(newbed, bed)


def test_cell_average_raised_bed_is_the_mean_sphere_top_and_emergent_cells_block():
    """The bed rises by the cell average of the sphere's top above it (the analytic cap, rastered
    independently of the remap); a cell is blocked where the top stands above the water (1 m) over at
    least half of it."""
    x, y = grid()
    bed = np.zeros((y.size, x.size))
    pos = np.array([[0.0, 0.0, 0.2]])
    r = np.array([1.0])
    obst, newbed = remap(x, y, bed, np.full(bed.shape, 1.0), pos, r, np.array([True]), mode="raised_bed",
                        sampling="cell_average")
    k = 64
    h = x[1] - x[0]
    o = ((np.arange(k) + 0.5) / k - 0.5) * h
    X = x[None, :, None, None] + o[None, None, None, :]
    Y = y[:, None, None, None] + o[None, None, :, None]
    d2 = X**2 + Y**2
    top = np.where(d2 < 1.0, 0.2 + np.sqrt(np.clip(1.0 - d2, 0, None)), 0.0)
    np.testing.assert_allclose(newbed, top.mean(axis=(2, 3)), atol=0.02)
    assert newbed.sum() * h * h == pytest.approx(np.pi * 0.2 + 2 / 3 * np.pi, rel=2e-3)  # the volume under the top
    frac = (top >= 1.0).mean(axis=(2, 3))
    sure = np.abs(frac - 0.5) > 0.05
    np.testing.assert_array_equal(obst[sure], frac[sure] >= 0.5)
    assert obst.any() and (newbed > 0).sum() > obst.sum()
    with pytest.raises(InputError, match="pile sampling"):
        remap(x, y, bed, bed, pos, r, np.array([True]), mode="raised_bed", sampling="corner")


def test_placement_is_seeded_per_cycle_and_respects_units():
    plan = PlacementPlan.from_config({"diameter": ["0.8 m", "1.2 m"], "batch": 3, "positions": "line",
                                      "start": [-10, 0], "stop": [10, 0], "release_height": "2 m", "rate": "30 1/hr"})
    surface = lambda x, y: np.full_like(x, 5.0)
    a = plan.release(4, seed=11, surface_at=surface)
    b = plan.release(4, seed=11, surface_at=surface)
    c = plan.release(4, seed=12, surface_at=surface)
    np.testing.assert_array_equal(a.pos, b.pos)
    assert not np.allclose(a.radius, c.radius)
    assert np.all((a.radius >= 0.4) & (a.radius <= 0.6))
    assert np.all(np.abs(a.pos[:, 0]) <= 10.5)
    # 12 masses after cycle 4 at 30 per hour: 24 minutes
    assert a.time == pytest.approx(12 / 30 * 3600)
    # no two masses of a batch overlap; each is >= 2 m above the surface
    for i in range(3):
        assert a.pos[i, 2] - a.radius[i] >= 5.0 + 2.0 - 1e-12
        for j in range(i):
            assert np.linalg.norm(a.pos[i] - a.pos[j]) >= a.radius[i] + a.radius[j]
    with pytest.raises(InputError, match="unknown key"):
        PlacementPlan.from_config({"diamter": "1 m"})
    with pytest.raises(InputError, match="outside the field"):
        plan.release(1, 0, lambda x, y: np.full_like(x, np.nan))


def test_incremental_pile_top_equals_the_full_recomputation():
    """Masses added, moved, stopping and starting to rest over many cycles: the incrementally kept pile
    top and cell quantities are the full ``pile_top`` / ``pile_cells`` of the current masses, bit for
    bit, while touching only the changes."""
    from breachflow.cycle.remap import IncrementalPileTop, pile_cells, pile_top

    rng = np.random.default_rng(3)
    x = np.arange(40) * 0.5
    y = np.arange(30) * 0.5 - 3.0
    bed = np.zeros((30, 40))
    pile = IncrementalPileTop(x, y, bed)
    pos, rad, rest = np.zeros((0, 3)), np.zeros(0), np.zeros(0, bool)
    for cycle in range(30):
        k = int(rng.integers(0, 6))
        pos = np.concatenate([pos, np.column_stack([rng.uniform(-1, 21, k), rng.uniform(-4, 12, k), rng.uniform(0, 2, k)])])
        rad = np.concatenate([rad, rng.uniform(0.1, 1.5, k)])
        rest = np.concatenate([rest, rng.random(k) < 0.7])
        moved = rng.random(rad.size) < 0.1
        pos[moved] += rng.normal(0.0, 0.5, (int(moved.sum()), 3))
        flip = rng.random(rad.size) < 0.1
        rest[flip] = ~rest[flip]
        top = pile.update(pos, rad, rest)
        np.testing.assert_array_equal(top, pile_top(x, y, bed, pos, rad, rest), err_msg=f"cycle {cycle}")
        lift, level = pile_cells(x, y, bed, pos, rad, rest)
        np.testing.assert_array_equal(pile.lift, lift, err_msg=f"cycle {cycle}")
        np.testing.assert_array_equal(pile.level, level, err_msg=f"cycle {cycle}")
        assert pile.last_changed <= k + int(moved.sum()) + int(flip.sum())
    # nothing changed: nothing recomputed
    pile.update(pos, rad, rest)
    assert pile.last_changed == 0
