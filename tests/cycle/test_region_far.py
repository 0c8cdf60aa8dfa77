"""The far field of the region re-solve (:mod:`breachflow.hydro.far_field`): the coarse model of the
domain against exact block averages, and the far-field level change against a lake at rest (no change)."""
import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.swe.porous import PorousPile
from breachflow.swe.domain import BoundaryCondition, uniform_grid
from breachflow.hydro.far_field import CoarseFarField, coarse_domain, far_fields


def _domain(nx=40, ny=30, dx=1.5, x0=-31.0, y0=-17.3):
    d = uniform_grid(x0, x0 + nx * dx, y0, y0 + ny * dx, dx)
    X, Y = np.meshgrid(d.x, d.y)
    d.bed = 0.02 * X - 0.05 * Y + 3.0
    d.manning = np.full(d.shape, 0.03)
    d.obstacle = np.zeros(d.shape, bool)
    return d


@pytest.mark.parametrize("factor", [2, 4])
def test_coarse_bed_of_a_plane_is_the_plane_at_the_coarse_centres(factor):
    # block means of a linear bed are the plane at the block centres (exact when the factor divides the cells)
    d = _domain()
    c, (jy, ix) = coarse_domain(d, factor)
    assert c.shape == (30 // factor if 30 % factor == 0 else round(30 / factor), 40 // factor)
    assert c.dx == pytest.approx(factor * d.dx) and c.x[0] - 0.5 * c.dx == pytest.approx(d.x[0] - 0.5 * d.dx)
    if 30 % factor == 0:
        Xc, Yc = np.meshgrid(c.x, c.y)
        np.testing.assert_allclose(c.bed, 0.02 * Xc - 0.05 * Yc + 3.0, atol=1e-12)
    # every fine cell lies in the coarse cell it is assigned to
    assert np.all(np.abs(d.x - c.x[ix]) <= 0.5 * c.dx + 1e-9) and np.all(np.abs(d.y - c.y[jy]) <= 0.5 * c.dy + 1e-9)


def test_coarse_obstacles_pile_and_boundaries():
    d = _domain()
    X, Y = np.meshgrid(d.x, d.y)
    # a wall 2 fine cells thick not aligned with the 2-cell blocks (rows 9, 10): blocks 4 (rows 8, 9) and
    # 5 (rows 10, 11) are each half blocked -> both no-flow; a wall one cell thick (row 20) stays a wall;
    # a quarter of a block blocked (row 26, columns 4..) is open
    d.obstacle[9:11, :] = True
    d.obstacle[20, :] = True
    d.obstacle[26, 4:] = True
    d.obstacle[27, 4:] = True
    pile_h = np.where((np.abs(X) < 4.0) & (np.abs(Y) < 2.0), 1.3, 0.0)
    d.porous = PorousPile.build(pile_h, np.full(d.shape, 0.4), np.full(d.shape, 2.0))
    d.bed[d.obstacle] = 99.0
    d.bed[20, 3] = 99.0
    prof = np.linspace(5.0, 6.0, d.x.size)
    d.boundaries = {"south": [BoundaryCondition.water_level(prof, absorbing=30.0)],
                    "west": [BoundaryCondition.outflow(start=0.0), BoundaryCondition.water_level(5.0, stop=0.0)]}
    c, _ = coarse_domain(d, 2)
    assert c.obstacle[4].all() and c.obstacle[5].all() and c.obstacle[10].all() and c.obstacle[13, 2:].all()
    assert not c.obstacle[[0, 1, 2, 3, 6, 7, 8, 9, 11, 12, 14]].any() and not c.obstacle[13, :2].any()
    # the bed of a partly blocked open block is that of its open cells (the 99 m of the blocked ones does not count)
    d.obstacle[:] = False
    d.obstacle[20, 3] = True
    c, _ = coarse_domain(d, 2)
    assert c.bed[10, 1] == pytest.approx(np.mean([d.bed[20, 2], d.bed[21, 2], d.bed[21, 3]]))
    # the pile's volume is kept, its porosity and stone size too
    area = d.dx * d.dy
    assert c.porous.height.sum() * c.dx * c.dy == pytest.approx(pile_h.sum() * area)
    assert np.allclose(c.porous.porosity[c.porous.height > 0], 0.4)
    # per-cell boundary values interpolated along the side; stretches kept
    np.testing.assert_allclose(c.boundaries["south"][0].level, np.interp(c.x, d.x, prof))
    assert c.boundaries["south"][0].absorbing == 30.0
    assert [b.kind for b in c.boundaries["west"]] == ["outflow", "level"]


def test_far_field_models_and_options():
    assert {"frozen", "coarse"} <= set(far_fields.available())
    assert far_fields.get("frozen")().level_change(None, None, None, None) is None
    with pytest.raises(InputError, match="factor"):
        CoarseFarField(None, factor=1)
    with pytest.raises(InputError, match="far-field"):
        far_fields.get("regional")


def test_the_coarse_far_field_keeps_a_lake_at_rest():
    """Still water behind a wall with a level boundary at the same level: a pile (raised bed) in the middle
    changes nothing, exactly (well-balanced); the coarse far field's level change is zero and the region
    re-solve with it returns the lake at rest."""
    import xarray as xr

    from breachflow.swe.solver import SWESolver
    from breachflow.hydro.resolve_region import RegionResolver

    d = _domain(nx=36, ny=28, dx=1.3, x0=-23.1, y0=-18.5)
    X, Y = np.meshgrid(d.x, d.y)
    d.bed = 0.5 + 0.03 * X + 0.02 * np.sin(0.3 * Y)
    level = 2.0
    d.boundaries = {"south": [BoundaryCondition.water_level(level, absorbing=20.0)]}
    h = np.maximum(level - d.bed, 0.0)
    zeros = np.zeros(d.shape)
    prev = xr.Dataset({"depth": (("y", "x"), h), "u": (("y", "x"), zeros), "v": (("y", "x"), zeros),
                       "bed_elevation": (("y", "x"), d.bed.copy()),
                       "obstacle": (("y", "x"), np.zeros(d.shape, "i1"))}, coords={"x": d.x, "y": d.y})
    piled = d.with_raised_bed((np.abs(X - 1.7) < 3.0) & (np.abs(Y + 0.4) < 2.0), 1.4)
    full = SWESolver(tolerance=1e-4, t_max=60.0, section=(-5.0, 5.0, 0.0))
    far = CoarseFarField(full, factor=2)
    changed = np.abs(piled.bed - d.bed) > 0
    jj, ii = np.nonzero(changed)
    d_eta = far.level_change(piled, prev, None, (jj.min(), jj.max() + 1, ii.min(), ii.max() + 1))
    assert np.max(np.abs(d_eta)) < 1e-9
    assert far.scale(0.0, 0.0) is None  # no discharge to scale by
    win = RegionResolver(full, margin=4.0, far="coarse", far_factor=2)
    ds = win.solve(piled, initial=prev)
    wet = ds.depth.values > 1e-3
    np.testing.assert_allclose((ds.bed_elevation.values + ds.depth.values)[wet], level, atol=1e-9)
    assert np.max(np.hypot(ds.u.values, ds.v.values)) < 1e-9
