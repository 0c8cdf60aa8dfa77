"""The polder's stage–storage curve from the terrain against closed-form volumes of analytic terrains."""
import numpy as np
import pytest

from breachflow.errors import InputError, ParseError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.storage import terrain_storage_curve


def _grid(x0, x1, y0, y1, d):
    x = np.arange(x0 + d / 2, x1, d)
    y = np.arange(y0 + d / 2, y1, d)
    return x, y, *np.meshgrid(x, y)


@pytest.mark.parametrize("d", [1.0, 0.5])
@pytest.mark.parametrize("seed_x", [99.9, 0.1, 50.0])  # the high edge, the low edge, the middle of the slope
def test_tilted_plane_volume_is_w_z2_over_2s(d, seed_x):
    # bed = s x on [0, L] x [0, W]: V(z) = W z^2 / (2 s) for 0 <= z <= s L, then W (L z - s L^2 / 2);
    # the water runs down the slope from any seed, so every seed gives the same curve
    s, L, W = 0.02, 100.0, 40.0
    x, y, X, _ = _grid(0.0, L, 0.0, W, d)
    z, v = terrain_storage_curve(s * X, x, y, (seed_x, W / 2), level_step=0.05)
    exact = np.where(z <= s * L, W * z ** 2 / (2 * s), W * (L * z - s * L ** 2 / 2))
    # cell-centred terrain: the midpoint rule of (z - s x)+ errs by at most W s d^2 / 8 per unit... bounded by
    # W d (s d) / 2 (half a cell column at the shoreline): compare in absolute terms with that bound
    bound = W * d * s * d / 2 + 1e-9
    assert np.abs(v - exact).max() <= bound
    inner = z > 0.2
    np.testing.assert_allclose(v[inner], exact[inner], rtol=0.01)
    assert z[0] == pytest.approx(s * d / 2) and z[-1] >= s * (L - d / 2)


@pytest.mark.parametrize("d", [1.0, 0.5])
def test_paraboloid_bowl_volume_is_pi_a_z2(d):
    # bed = r^2 / (2 a): the plan area at level z is pi r^2 = 2 pi a z, so V(z) = pi a z^2; the breach on
    # the rim (the water runs down into the bowl)
    a, R = 10.0, 30.0
    x, y, X, Y = _grid(-R, R, -R, R, d)
    bed = (X ** 2 + Y ** 2) / (2 * a)
    z, v = terrain_storage_curve(bed, x, y, (0.0, R - d), level_step=0.1)
    sel = (z >= 5.0) & (z <= R ** 2 / (2 * a))  # the level's circle inside the box
    exact = np.pi * a * z[sel] ** 2
    np.testing.assert_allclose(v[sel], exact, rtol=0.01)
    # the plan area dV/dz against 2 pi a z, over 1 m of level (the cells' plan area is a staircase of whole
    # cells: within a level step it jumps by a ring of cells)
    zs, vs = z[sel][::10], v[sel][::10]
    dv = np.diff(vs) / np.diff(zs)
    np.testing.assert_allclose(dv, 2 * np.pi * a * 0.5 * (zs[1:] + zs[:-1]), rtol=0.03)


def test_a_hollow_behind_a_ridge_is_not_storage_until_the_level_tops_the_ridge():
    # two bowls r^2 / (2 a) centred at x = -30 and x = +30, the ridge between them at x = 0 at least 45 m
    # high; the breach at the bottom of the western bowl: below the ridge only that bowl stores water
    a, d = 10.0, 0.5
    x, y, X, Y = _grid(-60.0, 60.0, -30.0, 30.0, d)
    bed = np.where(X < 0, (X + 30) ** 2 + Y ** 2, (X - 30) ** 2 + Y ** 2) / (2 * a)
    z, v = terrain_storage_curve(bed, x, y, (-30.0, 0.0), level_step=0.25)
    below = (z >= 5.0) & (z <= 44.0)
    np.testing.assert_allclose(v[below], np.pi * a * z[below] ** 2, rtol=0.01)
    # counting every cell below the level (no connection to the breach) would double it
    naive = np.array([d * d * np.clip(zz - bed, 0, None).sum() for zz in z[below]])
    np.testing.assert_allclose(naive, 2 * np.pi * a * z[below] ** 2, rtol=0.01)
    # once the level tops the ridge (45 m at y = 0) the eastern bowl fills with it
    k = np.searchsorted(z, 46.0)
    assert v[k] > 1.8 * np.pi * a * z[k] ** 2


def test_region_polygon_and_box_restrict_the_storage():
    # a flat-bottomed basin: bed 0 everywhere; a box of 20 x 10 m and a triangle of half of it
    x, y, X, _ = _grid(0.0, 40.0, 0.0, 40.0, 0.5)
    bed = np.zeros_like(X)
    z, v = terrain_storage_curve(bed, x, y, (5.0, 5.0), region=[0, 20, 0, 10], level_step=0.5)
    np.testing.assert_allclose(v, 200.0 * z, rtol=1e-12)
    z, v = terrain_storage_curve(bed, x, y, (5.0, 2.0), region=[[0, 0], [20, 0], [20, 10]], level_step=0.5)
    np.testing.assert_allclose(v, 100.0 * z, rtol=0.03)
    with pytest.raises(InputError, match="outside the polder region"):
        terrain_storage_curve(bed, x, y, (30.0, 30.0), region=[0, 20, 0, 10])


def test_polder_section_builds_the_polder_from_the_flow_models_terrain():
    # the bowl as the flow model's terrain, its protected side y > 0; the seed one cell landward of (0, 0)
    a, d = 10.0, 0.5
    x, y, X, Y = _grid(-30.0, 30.0, -30.0, 30.0, d)
    bed = (X ** 2 + Y ** 2) / (2 * a)
    sc = parse_scenario('[polder]\nstorage = "terrain"\nlevel_step = "10 cm"\npump_capacity = "1 m^3/s"\n')
    protected = np.broadcast_to((y > 0)[:, None], bed.shape)
    pol = sc["polder"].polder(0.0, (bed, x, y, (0.0, d), protected))
    # half the bowl: V = pi a z^2 / 2 above the initial level 0; area = the half-square's plan area
    for zz in (10.0, 20.0, 40.0):
        assert pol.volume(zz) == pytest.approx(np.pi * a * zz ** 2 / 2, rel=0.01)
        assert pol.level(np.pi * a * zz ** 2 / 2) == pytest.approx(zz, rel=0.01)
    assert pol.area == pytest.approx(60.0 * 30.0, rel=1e-9) and pol.pump_capacity == 1.0


@pytest.mark.parametrize("lines, key, message", [
    ('storage = "dem"', "storage", "unknown storage 'dem'"),
    ('storage = "terrain"\nregion = [1, 2, 3]', "region", r"region must be a box .* got \[1, 2, 3\]"),
    ('storage = "terrain"\nregion = [0, 0, 1, 5]', "region", "has no area"),
    ('storage = "terrain"\nseed = ["breach", 1]', "seed", "seed must be \\[x, y\\]"),
    ('storage = "terrain"\nseed = "breach"', "seed", "expected list"),
    ('storage = "terrain"\nlevel_step = "-1 m"', "level_step", "level_step"),
    ('area = "10 ha"\nregion = [0, 1, 0, 1]', "region", "needs storage = \"terrain\""),
    ('storage = "terrain"\nterrain = "polder.tif"', "terrain", "needs seed"),
])
def test_bad_terrain_storage_keys_name_file_line_key_and_value(tmp_path, lines, key, message):
    (tmp_path / "polder.tif").write_bytes(b"")
    path = tmp_path / "s.toml"
    text = f"[polder]\n{lines}\n"
    path.write_text(text)
    with pytest.raises(ParseError, match=message) as info:
        parse_scenario(text, path)
    err = info.value
    assert err.path == str(path) and f"[polder] {key}" in str(err)
    assert err.line == next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith(key))


def test_terrain_storage_without_a_terrain_is_refused():
    sc = parse_scenario('[polder]\nstorage = "terrain"\n')
    with pytest.raises(InputError, match="no terrain to integrate"):
        sc["polder"].polder(0.0, None)


def test_closure_setup_takes_the_polder_storage_from_the_flow_models_terrain():
    # the CI closure scene: 12 m breach with 16 m of levee each side (44 m along the levee), 20 m to the
    # protected side; above the levee crest the whole protected side stores water: 44 m x 20 m
    from pathlib import Path

    from breachflow.cycle.config import closure_setup
    from breachflow.scenario.toml import scenario_with

    text = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()
    text = scenario_with(text, {"closure.method": "split_barge", "polder.storage": "terrain",
                                "polder.level_step": "5 cm"})
    setup = closure_setup(parse_scenario(text))
    pol = setup.timeline.polder
    assert pol.area == pytest.approx(44.0 * 20.0, rel=1e-9)
    zc, vc = pol.curve
    dom = setup.domain
    protected = np.asarray(dom.bed)[np.asarray(dom.y) > setup.levee_y]
    assert zc[0] == pytest.approx(protected.min(), abs=1e-12)  # from the lowest ground of the protected side
    assert pol.plan_area(zc[-1] + 1.0) == pytest.approx(880.0, rel=1e-6)


def test_closure_setup_takes_the_polder_storage_from_a_geotiff(tmp_path):
    # a paraboloid bowl r^2 / (2 a) - 10 m in a GeoTIFF (rows north to south, UTM coordinates), the breach's
    # landside cell on its rim: V(z) = pi a (z + 10)^2, counted above the polder's initial level 0 m
    rasterio = pytest.importorskip("rasterio")
    from pathlib import Path

    from rasterio.transform import from_origin

    from breachflow.cycle.config import closure_setup
    from breachflow.scenario.toml import scenario_with

    a, pix, e0, n0 = 10.0, 0.5, 500000.0, 4100000.0
    xc = e0 + (np.arange(160) + 0.5) * pix
    yc = n0 + 80 - (np.arange(160) + 0.5) * pix
    X, Y = np.meshgrid(xc, yc)
    bed = ((X - e0 - 40) ** 2 + (Y - n0 - 40) ** 2) / (2 * a) - 10.0
    with rasterio.open(tmp_path / "polder.tif", "w", driver="GTiff", width=160, height=160, count=1,
                       dtype="float64", crs="EPSG:32615", transform=from_origin(e0, n0 + 80, pix, pix)) as dst:
        dst.write(bed, 1)
    text = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()
    text = scenario_with(text, {"closure.method": "split_barge", "polder.storage": "terrain",
                                "polder.terrain": str(tmp_path / "polder.tif"), "polder.seed": [e0 + 40, n0 + 75],
                                "polder.initial_level": "0 m"})
    pol = closure_setup(parse_scenario(text)).timeline.polder
    for z in (0.0, 5.0, 30.0):
        assert pol.volume(z) == pytest.approx(np.pi * a * ((z + 10) ** 2 - 100.0), rel=0.01, abs=1.0)
