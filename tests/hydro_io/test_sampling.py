"""FieldSampler: bilinear / barycentric / neighbourhood sampling against independent references."""
import numba
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.interpolate import LinearNDInterpolator, RegularGridInterpolator
from scipy.spatial import Delaunay

from breachflow import InputError
from breachflow.field import DRY_DEPTH, FieldSampler, grid_snapshot, mesh_snapshot, uniform_snapshot
from breachflow.field.sampling import SAMPLING_METHODS, grid_bilinear_point
from breachflow.schemas import validate


def _grid(nx=12, ny=9, dx=2.0, dy=1.5, x0=100.0, y0=-20.0, seed=0):
    rng = np.random.default_rng(seed)
    x = x0 + dx * np.arange(nx)
    y = y0 + dy * np.arange(ny)
    bed = rng.normal(0, 1, (ny, nx))
    depth = rng.uniform(0.5, 3.0, (ny, nx))
    u = rng.normal(0, 1, (ny, nx))
    v = rng.normal(0, 1, (ny, nx))
    return x, y, bed, depth, u, v


def test_bilinear_matches_scipy_regular_grid_interpolator():
    x, y, bed, depth, u, v = _grid()
    ds = grid_snapshot(x, y, bed, depth, u, v)
    rng = np.random.default_rng(1)
    px = rng.uniform(x[0], x[-1], 500)
    py = rng.uniform(y[0], y[-1], 500)
    s = FieldSampler(ds, "bilinear").sample(px, py)
    for field, got in ((depth, s.depth), (bed, s.bed), (u, s.u), (v, s.v)):
        ref = RegularGridInterpolator((y, x), field)(np.column_stack([py, px]))
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s.surface, s.bed + s.depth)
    assert s.inside.all()


def test_bilinear_reproduces_bilinear_functions_and_flags_outside():
    x = np.linspace(0.0, 10.0, 11)
    y = np.linspace(-5.0, 5.0, 6)
    X, Y = np.meshgrid(x, y)
    f = lambda a, b: 2.0 + 0.3 * a - 0.2 * b + 0.01 * a * b  # noqa: E731  bilinear: reproduced exactly
    ds = grid_snapshot(x, y, np.zeros_like(X), f(X, Y), 0 * X, 0 * X)
    px = np.array([0.0, 3.3, 9.99, 10.0, -0.6, 10.6, 5.0, 5.0])
    py = np.array([-5.0, 1.7, 4.99, 5.0, 0.0, 0.0, 7.1, -7.1])
    s = FieldSampler(ds).sample(px, py)
    np.testing.assert_allclose(s.depth[:4], f(px[:4], py[:4]), rtol=1e-13)
    assert not s.inside[4:].any()
    assert np.isnan(s.depth[4:]).all() and np.isnan(s.u[4:]).all() and np.isnan(s.surface[4:]).all()
    # within the outer half cell: the edge cell value (no extrapolation)
    e = FieldSampler(ds).sample([10.4, -0.4], [0.0, 2.0])
    np.testing.assert_allclose(e.depth, [f(10.0, 0.0), f(0.0, 2.0)])
    assert e.inside.all()


def test_dry_points_have_zero_velocity_and_surface_on_bed():
    x = np.arange(5.0)
    y = np.arange(3.0)
    depth = np.zeros((3, 5))
    depth[:, 3:] = 1.0
    ds = grid_snapshot(x, y, np.full((3, 5), 2.0), depth, np.ones((3, 5)), np.ones((3, 5)))
    s = FieldSampler(ds).sample([0.5, 2.0, 3.5], [1.0, 1.0, 1.0])
    assert s.depth[0] == 0 and s.u[0] == 0 and s.v[0] == 0 and s.surface[0] == 2.0
    # half-way between a dry and a wet column: depth 0.5, velocity interpolated from 0 (dry) to 1
    s2 = FieldSampler(ds).sample([2.5], [1.0])
    assert s2.depth[0] == pytest.approx(0.5) and s2.u[0] == pytest.approx(0.5)
    assert s.depth[2] == 1.0 and s.u[2] == 1.0


def test_descending_axes_are_handled():
    x, y, bed, depth, u, v = _grid()
    ds = grid_snapshot(x[::-1], y[::-1], bed[::-1, ::-1], depth[::-1, ::-1], u[::-1, ::-1], v[::-1, ::-1])
    ref = grid_snapshot(x, y, bed, depth, u, v)
    px, py = np.array([101.3, 115.0]), np.array([-19.0, -10.2])
    np.testing.assert_allclose(FieldSampler(ds).sample(px, py).u, FieldSampler(ref).sample(px, py).u)


def _brute_neighbourhood(gx, gy, vals, px, py, r):
    d2 = (gx - px) ** 2 + (gy - py) ** 2
    m = d2 <= r * r
    return vals[m].mean(), m.sum()


def test_neighbourhood_grid_matches_brute_force_for_large_and_small_particles():
    x, y, bed, depth, u, v = _grid(nx=30, ny=20, dx=1.0, dy=0.8)
    ds = grid_snapshot(x, y, bed, depth, u, v)
    X, Y = np.meshgrid(x, y)
    smp = FieldSampler(ds, "neighbourhood")
    assert smp.s_max == pytest.approx(1.0)
    rng = np.random.default_rng(3)
    px = rng.uniform(x[0], x[-1], 50)
    py = rng.uniform(y[0], y[-1], 50)
    radius = np.where(np.arange(50) % 2 == 0, 0.1, 2.7)  # small (uses s_max = 1.0) and large particles
    s = smp.sample(px, py, radius)
    for k in range(50):
        r = max(radius[k], 1.0)
        ref_u, n = _brute_neighbourhood(X, Y, u, px[k], py[k], r)
        ref_h, _ = _brute_neighbourhood(X, Y, depth, px[k], py[k], r)
        assert n >= 1
        assert s.u[k] == pytest.approx(ref_u, rel=1e-12)
        assert s.depth[k] == pytest.approx(ref_h, rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.5, 29.5), st.floats(-0.4, 15.6), st.floats(0, 0.99))
def test_neighbourhood_never_empty_inside_the_field(px, py, r):
    x, y, bed, depth, u, v = _grid(nx=30, ny=20, dx=1.0, dy=0.8, x0=0.0, y0=0.0)
    s = FieldSampler(grid_snapshot(x, y, bed, depth, u, v), "neighbourhood").sample([px], [py], r)
    assert s.inside[0] and np.isfinite(s.depth[0]) and np.isfinite(s.u[0])


def _mesh(n=400, seed=5):
    rng = np.random.default_rng(seed)
    pts = np.vstack([rng.uniform(0, 100, (n, 2)), [[0, 0], [100, 0], [0, 100], [100, 100]]])
    tri = Delaunay(pts)
    return pts, tri


def test_barycentric_matches_scipy_linear_nd_interpolator():
    pts, tri = _mesh()
    rng = np.random.default_rng(6)
    depth = rng.uniform(0.2, 4.0, len(pts))
    u = rng.normal(0, 1, len(pts))
    v = rng.normal(0, 1, len(pts))
    bed = rng.normal(0, 1, len(pts))
    ds = mesh_snapshot(pts[:, 0], pts[:, 1], tri.simplices, bed, depth, u, v)
    q = rng.uniform(-10, 110, (2000, 2))
    s = FieldSampler(ds, "barycentric").sample(q[:, 0], q[:, 1])
    for field, got in ((depth, s.depth), (u, s.u), (v, s.v), (bed, s.bed)):
        ref = LinearNDInterpolator(tri, field)(q)
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9)  # NaN outside in both
    inside_ref = tri.find_simplex(q) >= 0
    np.testing.assert_array_equal(s.inside, inside_ref)


def test_barycentric_exact_for_linear_field_on_quads_and_triangles():
    # 3 x 2 nodes: two quads; a linear field is reproduced exactly on both split triangles
    nx_ = np.array([0.0, 1.0, 2.0, 0.0, 1.0, 2.0])
    ny_ = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    faces = np.array([[0, 1, 4, 3], [1, 2, 5, -1]])
    lin = 1.0 + 0.5 * nx_ + 0.25 * ny_
    ds = mesh_snapshot(nx_, ny_, faces, 0 * nx_, lin, 0 * nx_, 0 * nx_)
    px = np.array([0.2, 0.8, 1.6, 1.2])
    py = np.array([0.7, 0.1, 0.3, 0.9])
    s = FieldSampler(ds).sample(px, py)
    assert list(s.inside) == [True, True, True, False]  # (1.2, 0.9) lies in the missing half of the 2nd quad
    np.testing.assert_allclose(s.depth[:3], 1.0 + 0.5 * px[:3] + 0.25 * py[:3], rtol=1e-13)


def test_neighbourhood_on_mesh_matches_brute_force():
    pts, tri = _mesh(n=300, seed=8)
    rng = np.random.default_rng(9)
    u = rng.normal(0, 1, len(pts))
    depth = rng.uniform(0.5, 1.0, len(pts))
    ds = mesh_snapshot(pts[:, 0], pts[:, 1], tri.simplices, 0 * u, depth, u, 0 * u)
    smp = FieldSampler(ds, "neighbourhood")
    edges = np.concatenate([tri.simplices[:, [0, 1]], tri.simplices[:, [1, 2]], tri.simplices[:, [2, 0]]])
    assert smp.s_max == pytest.approx(np.hypot(*(pts[edges[:, 0]] - pts[edges[:, 1]]).T).max())
    q = rng.uniform(1, 99, (40, 2))
    radius = np.where(np.arange(40) % 2 == 0, 0.0, 2.5 * smp.s_max)
    s = smp.sample(q[:, 0], q[:, 1], radius)
    for k in range(40):
        r = max(radius[k], smp.s_max)
        ref, n = _brute_neighbourhood(pts[:, 0], pts[:, 1], u, q[k, 0], q[k, 1], r)
        assert n >= 3
        assert s.u[k] == pytest.approx(ref, rel=1e-12)


def test_uniform_snapshot_and_units():
    ds = uniform_snapshot("2 ft", u="1 ft/s", bed="-1 m", extent=(0, 10, 0, 5), spacing="50 cm")
    validate(ds, "snapshot_grid")
    assert ds.sizes == {"x": 21, "y": 11}
    s = FieldSampler(ds).sample(np.array([[0.0, 10.0], [3.3, 7.7]]), np.array([[0.0, 5.0], [2.2, 4.4]]))
    assert s.depth.shape == (2, 2)
    np.testing.assert_allclose(s.depth, 0.6096)
    np.testing.assert_allclose(s.u, 0.3048)
    np.testing.assert_allclose(s.surface, -1 + 0.6096)
    assert s.inside.all()


def test_time_index_and_bad_input():
    x, y = np.arange(3.0), np.arange(2.0)
    depth = np.stack([np.ones((2, 3)), 2 * np.ones((2, 3))])
    ds = grid_snapshot(x, y, np.zeros((2, 3)), depth, depth, 0 * depth, time=[0.0, 60.0])
    assert FieldSampler(ds, time_index=0).sample([1.0], [0.5]).depth[0] == 1.0
    assert FieldSampler(ds).sample([1.0], [0.5]).depth[0] == 2.0  # default: last step
    with pytest.raises(InputError, match="time_index"):
        FieldSampler(ds, time_index=5)
    with pytest.raises(InputError, match="unknown sampling method 'cubic'"):
        FieldSampler(ds, "cubic")
    with pytest.raises(InputError, match="radius"):
        FieldSampler(ds, "neighbourhood").sample([1.0], [0.5], radius=-1.0)
    assert {"bilinear", "barycentric", "neighbourhood", "neighborhood"} <= set(SAMPLING_METHODS.available())


def test_grid_arrays_are_usable_from_a_user_numba_kernel():
    x, y, bed, depth, u, v = _grid()
    smp = FieldSampler(grid_snapshot(x, y, bed, depth, u, v))
    ga = smp.grid_arrays()

    @numba.njit
    def mean_depth(bed, depth, u, v, x0, y0, dx, dy, px, py):
        acc = 0.0
        for k in range(px.size):
            ok, b, h, uu, vv = grid_bilinear_point(bed, depth, u, v, x0, y0, dx, dy, px[k], py[k])
            acc += h
        return acc / px.size

    px = np.array([101.0, 110.5, 120.0])
    py = np.array([-19.0, -15.0, -9.0])
    assert mean_depth(*ga, px, py) == pytest.approx(smp.sample(px, py).depth.mean())
    with pytest.raises(InputError, match="mesh_arrays"):
        smp.mesh_arrays()
    assert DRY_DEPTH == 1e-6  # the kernels hard-code this threshold


def test_large_batches_sorted_by_bucket_give_identical_results():
    pts, tri = _mesh(n=2000, seed=11)
    rng = np.random.default_rng(12)
    u = rng.normal(0, 1, len(pts))
    ds = mesh_snapshot(pts[:, 0], pts[:, 1], tri.simplices, 0 * u, 1 + 0 * u, u, -u)
    q = rng.uniform(-5, 105, (3 * FieldSampler.SORT_THRESHOLD, 2))
    smp = FieldSampler(ds)
    assert not np.array_equal(smp.locality_order(q[:, 0], q[:, 1]), np.arange(len(q)))
    sorted_run = smp.sample(q[:, 0], q[:, 1])
    chunks = [smp.sample(q[k:k + 1000, 0], q[k:k + 1000, 1]) for k in range(0, len(q), 1000)]  # unsorted path
    np.testing.assert_array_equal(sorted_run.u, np.concatenate([c.u for c in chunks]))
    np.testing.assert_array_equal(sorted_run.inside, np.concatenate([c.inside for c in chunks]))


@pytest.mark.parametrize("method", ["bilinear", "neighbourhood"])
def test_fallback_field_is_sampled_outside_the_primary_field_only(method):
    """``FieldSampler(local, fallback=regional)``: the local field where it exists, the regional one
    (same method) outside it, nothing outside both; the regional grid and a mesh as fallback."""
    x, y, bed, depth, u, v = _grid(nx=40, ny=30, dx=2.0, dy=2.0, x0=-40.0, y0=-30.0, seed=3)
    regional = grid_snapshot(x, y, bed, depth, u, v)
    local = uniform_snapshot(1.7, u=-0.3, v=0.9, bed=0.2, extent=(-6.0, 6.0, -4.0, 4.0), spacing=0.5)
    rng = np.random.default_rng(4)
    px, py = rng.uniform(-45.0, 45.0, 3000), rng.uniform(-35.0, 35.0, 3000)
    r = rng.uniform(0.0, 3.0, 3000)
    s = FieldSampler(local, method, fallback=regional).sample(px, py, r)
    s_loc = FieldSampler(local, method).sample(px, py, r)
    s_reg = FieldSampler(regional, method).sample(px, py, r)
    ins = s_loc.inside
    assert ins.any() and (~ins & s_reg.inside).any() and (~s_reg.inside).any()
    for name in ("bed", "depth", "surface", "u", "v"):
        got, a, b = getattr(s, name), getattr(s_loc, name), getattr(s_reg, name)
        np.testing.assert_array_equal(got[ins], a[ins])
        np.testing.assert_array_equal(got[~ins], b[~ins])
    np.testing.assert_array_equal(s.inside, ins | s_reg.inside)
    # a sampler as fallback (the nested solver's, built once) gives the same
    s2 = FieldSampler(local, method, fallback=FieldSampler(regional, method)).sample(px, py, r)
    np.testing.assert_array_equal(s2.u, s.u)
    with pytest.raises(InputError, match="fallback"):
        FieldSampler(local, method, fallback="regional.nc")
