"""The erodible bed between cycles: the Meyer-Peter–Müller / Exner bed change of a cycle's flow lowers the terrain
the SWE re-solves on; a bottom protection over a region holds where its stones' threshold holds; the bed's volume
is conserved; the bed model is named in the verdict."""
import json
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.config.bed import BedSettings
from breachflow.cycle.main import run_closure
from breachflow.cycle.scour import cycle_bed_change, grain_map
from breachflow.errors import InputError, ParseError
from breachflow.fluid.bed import BedRoughness, ProtectionRegion
from breachflow.scenario.config import parse_scenario
from breachflow.swe.domain import uniform_grid

from .test_snapshot_frozen import BASE

G = 9.80665
RHO, RHO_S, P = 1000.0, 2650.0, 0.4


def flume(nx=20, ny=6, dx=2.0, speed=3.0, depth=2.0, slow_rows=0):
    """A flat flume, flow along +x at *speed* (slower, 0.3 m/s, in the first *slow_rows* rows)."""
    dom = uniform_grid(0.0, nx * dx, 0.0, ny * dx, dx, bed=0.0, manning=0.025)
    u = np.full(dom.shape, speed)
    u[:slow_rows] = 0.3
    ds = xr.Dataset({"depth": (("y", "x"), np.full(dom.shape, depth)), "u": (("y", "x"), u),
                     "v": (("y", "x"), np.zeros(dom.shape))}, coords={"x": dom.x, "y": dom.y})
    return dom, ds


def setup_of(dom, d, protection=None, steps=2000):
    bed = BedSettings(BedRoughness("natural", d), None, True, protection, True, steps)
    return SimpleNamespace(domain=dom, dem=SimpleNamespace(bed=bed))


def mpm_rate(speed, depth, d, n=0.025):
    """-dz/dt (m/s) at the inflow edge cell of a uniform flume: what leaves through its downstream face."""
    tau = RHO * G * n * n * speed ** 2 / depth ** (1 / 3)
    theta = tau / ((RHO_S - RHO) * G * d)
    qb = 8.0 * max(theta - 0.047, 0.0) ** 1.5 * np.sqrt((RHO_S - RHO) / RHO * G * d ** 3)
    return qb, theta


def test_the_inflow_cell_lowers_at_the_mpm_rate():
    """Clear water: nothing enters the first column, its bed load leaves: dz = -q_b dt / ((1 - p) dx) (hand
    arithmetic of Meyer-Peter & Müller 1948 and Exner), interior cells of the uniform flume do not change."""
    dom, ds = flume()
    d = 0.01
    qb, theta = mpm_rate(3.0, 2.0, d)
    assert theta > 0.047
    dt = 0.5
    new, info = cycle_bed_change(setup_of(dom, d), ds, dt)
    drop = dom.bed - new
    assert drop[:, 0] == pytest.approx(qb * dt / ((1 - P) * dom.dx), rel=1e-9)
    assert np.abs(drop[:, 1:-1]).max() < 1e-12
    assert info["bed_lowering"] == pytest.approx(drop.max()) and info["bed_change_time"] == pytest.approx(dt)


def test_the_bed_volume_is_conserved_in_a_closed_box():
    rng = np.random.default_rng(3)
    dom, ds = flume(nx=16, ny=12)
    ds["u"][:] = rng.uniform(-4, 4, dom.shape)
    ds["v"][:] = rng.uniform(-4, 4, dom.shape)
    ds["depth"][:] = rng.uniform(1, 3, dom.shape)
    new, info = cycle_bed_change(setup_of(dom, 0.005), ds, 60.0, open_edges=False)
    assert info["bed_lowering"] > 0.0 and info["bed_rise"] > 0.0
    assert np.sum(new - dom.bed) == pytest.approx(0.0, abs=1e-10 * np.abs(new - dom.bed).sum())


def test_protected_cells_do_not_erode_the_unprotected_toe_scours():
    """A protection of 0.5 m stones over the middle of a flume of 2 cm gravel: under it Shields' parameter stays
    below the threshold and the bed never lowers; downstream of it (the toe) the gravel scours where the shear
    exceeds Shields' threshold, and not in the slow rows where it does not."""
    dom, ds = flume(nx=20, ny=8, slow_rows=3)
    prot = ProtectionRegion(0.5, 1.0, box=(10.0, 26.0, -1.0, 17.0))
    assert mpm_rate(3.0, 2.0, 0.5)[1] < 0.047 < mpm_rate(3.0, 2.0, 0.02)[1]
    assert mpm_rate(0.3, 2.0, 0.02)[1] < 0.047
    setup = setup_of(dom, 0.02, prot)
    d = grain_map(setup.dem.bed, dom.x, dom.y)
    inside = prot.mask(dom.x, dom.y)
    assert inside.any() and (d[inside] == 0.5).all() and (d[~inside] == 0.02).all()
    new, info = cycle_bed_change(setup, ds, 3600.0)
    drop = dom.bed - new
    assert drop[inside].max() <= 0.0  # no protected cell erodes (what comes from upstream may settle on it)
    toe = (dom.x[None, :] > 26.0) & (np.arange(dom.shape[0])[:, None] >= 3)
    assert toe.any() and (drop[:, dom.x > 26.0][3:] > 0).any()
    # the cell just beyond the protection: nothing comes in from the stones, its bed load leaves
    i = int(np.flatnonzero(dom.x > 26.0)[0])
    assert (drop[3:, i] > 0).all()
    assert np.abs(drop[:3]).max() == 0.0  # below the threshold nothing moves
    assert info["bed_lowering"] == pytest.approx(drop.max())


def test_protection_region_errors_name_the_key():
    bad = ['grain_size = "2 cm"\nprotection = { grain_size = "1 m", box = ["1 m", "0 m", "0 m", "1 m"] }',
           'grain_size = "2 cm"\nprotection = { grain_size = "1 m" }',
           'grain_size = "2 cm"\nprotection = { grain_size = "1 m", box = [1, 2, 3] }',
           'grain_size = "2 cm"\nprotection = { grain_size = "1 m", thickness = "0.5 m", box = [0, 1, 0, 1] }',
           'grain_size = "2 cm"\nprotection = { grain_size = "1 m", spacing = 2, box = [0, 1, 0, 1] }',
           'kind = "protection"\ngrain_size = "1 m"\nprotection = { grain_size = "1 m", box = [0, 1, 0, 1] }']
    for text in bad:
        with pytest.raises((InputError, ParseError), match=r"\[bed\] protection"):
            parse_scenario(_scenario(text))
    with pytest.raises(InputError, match="polygon needs at least 3"):
        ProtectionRegion(1.0, 1.0, polygon=((0, 0), (1, 1)))


def test_a_polygon_protection_covers_its_cells():
    p = ProtectionRegion(1.0, 2.0, polygon=((-5, -5), (5, -5), (0, 5)))
    x = np.array([-4.0, 0.0, 4.0])
    y = np.array([-4.0, 4.0])
    np.testing.assert_array_equal(p.mask(x, y), [[True, True, True], [False, True, False]])


def _scenario(bed, solver="swe"):
    return BASE.replace("{solver}", solver).replace('snapshots = ["{snap}"]', "") + "\n[bed]\n" + bed


def test_the_swe_re_solves_on_the_lowered_terrain_and_a_resume_keeps_it(tmp_path):
    """An erodible gravel floor in the demo breach: cycle 1's flow lowers the terrain (reported), cycle 2's
    snapshot is solved on it, the restart record keeps it; with the breach floor protected it holds."""
    sc = tmp_path / "bed.toml"
    text = _scenario('grain_size = "2 mm"\nerodible = true\nnear_bed = false').replace(
        "max_speed = \"0.01 m/s\"", "max_speed = \"0.01 m/s\"\nmode = \"any\"")
    sc.write_text(text)
    setup = closure_setup(parse_scenario(text))
    bed0 = np.array(setup.domain.bed)
    run_closure(sc, tmp_path / "run", plots=False)
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    s1 = man["cycles"][0]["summary"]
    assert s1["bed_lowering"] > 0.0 and s1["bed_change_time"] > 0.0 and np.isfinite(s1["bed_lowering_x"])
    files = sorted((tmp_path / "run").glob("cycle_*.nc"))
    assert len(files) == 2
    with xr.open_dataset(files[1]) as c2:
        bed2 = c2["bed_elevation"].isel(cycle=0).values if "cycle" in c2["bed_elevation"].dims else c2["bed_elevation"].values
    lowered = bed2 < bed0 - 1e-9
    assert lowered.any()  # the second cycle's flow is solved on the lowered terrain
    assert (bed0 - bed2).max() == pytest.approx(s1["bed_lowering"], rel=1e-9)
    from breachflow.io import RunDirectory

    rec = RunDirectory(tmp_path / "run").load_restart(1)
    assert (np.asarray(rec["terrain_bed"]) < bed0 - 1e-9).any()


def test_the_verdict_names_the_bed_model():
    from breachflow.ensemble.check import CheckRun, bed_model, judge

    runs = [CheckRun(label="4 m", cell_size=4, seed=1, closed=True, tonnage=100.0, lost_tonnage=0.0, cycles=2,
                     discharge=100.0, gap_mean_speed=5.0, gap_max_speed=6.0, own=True)]
    words = bed_model(parse_scenario(_scenario(
        'grain_size = "0.3 mm"\nerodible = true\n'
        'protection = { grain_size = "1 m", thickness = "2 m", box = ["-10 m", "10 m", "-8 m", "8 m"] }')))
    assert words.startswith("natural bed of 0.3 mm grains, bottom protection of 1 m stones (2 m) over box x -10..10 m")
    assert "erodible (the terrain follows the Exner bed change between cycles)" in words
    r = judge(runs, 0.02, bed=words)
    assert r.statement.endswith("— bed: " + words) and ("  bed model of the check", words) in r.rows()
    # the summary table names the bed once, in its own row, not again at the end of the verdict
    verdict = dict(r.rows())["verdict check"]
    assert words not in verdict and verdict == r.statement[: -len(" — bed: " + words)]
    assert r.summary()["bed_model"] == words and r.dataset().attrs["bed_model"] == words
    assert bed_model(parse_scenario(_scenario('kind = "protection"\ngrain_size = "1 m"\nthickness = "2 m"'))) == \
        "bottom protection of 1 m stones, 2 m thick, over the whole bed, not erodible"
    assert bed_model(parse_scenario(BASE.replace("{solver}", "swe").replace('snapshots = ["{snap}"]', ""))) \
        .startswith("smooth bed (no [bed] section")
