"""The breach discharge counts from the flood side into the polder, whichever side of the grid the flood is on.

The example site (the river south of the levee) and its mirror image about the levee centreline (the river
north of it: the same terrain flipped north-south, the same levee line mirrored, still digitised west to
east, so the flood is now on its left) are the same breach: every discharge a run reports — the open breach
in the manifest and the run's result, the ``breach_discharge`` CF variable of the cycle files, the
ensemble member's result that the atlas's detailed tier collects — must be the same positive number both
ways, and the closure in time must calibrate its weir on it both ways (a negative discharge would skip the
calibration and drain the polder instead of filling it).
"""
import json
import tomllib

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import section_discharge
from breachflow.cycle.main import run_closure
from breachflow.ensemble.closure import ClosureRunner
from breachflow.ensemble.runners import MemberScenario
from breachflow.scenario.config import load_scenario
from breachflow.scenario.toml import scenario_with
from breachflow.swe.section import flow_sign, snapshot_discharge

from .conftest import SITE

rasterio = pytest.importorskip("rasterio")

LEVEE_Y = 3372100.0  # northing of the example levee at the breach (examples/site/make_site.py): the mirror axis
IDEAL_WEIR = 3.1 * 0.3048 ** 0.5  # the report's broad-crested weir coefficient, m^0.5/s, before calibration

# a CI-sized run of the example site: 2 m cells, one cycle of two masses, the closure in time by split barge
# (the weir calibrated on the open breach at the start, 0.5 h after the breach, into a 200 ha polder)
RUN = {"hydro.resolution": "2 m", "hydro.t_max_initial": "200 s", "hydro.t_max": "20 s",
       "dem.max_time": "2 s", "placement.batch": 2, "placement.diameter": ["1.8 m", "2.0 m"],
       "criteria.max_cycles": 1, "closure.method": "split_barge", "closure.start": "0.5 h",
       "polder.area": "200 ha", "closure.seed": 1}


def _mirrored(out):
    """The example terrain flipped north-south about the levee line and the levee mirrored with it."""
    out.mkdir(parents=True, exist_ok=True)
    with rasterio.open(SITE / "terrain.tif") as src:
        z, prof, t, b = src.read(1), src.profile, src.transform, src.bounds
    prof.update(transform=rasterio.transform.from_origin(b.left, 2 * LEVEE_Y - b.bottom, t.a, -t.e))
    with rasterio.open(out / "terrain.tif", "w", **prof) as dst:
        dst.write(np.ascontiguousarray(z[::-1]), 1)
    g = json.loads((SITE / "levee.geojson").read_text())
    geom = g["features"][0]["geometry"]
    geom["coordinates"] = [[x, 2 * LEVEE_Y - y] for x, y in geom["coordinates"]]
    (out / "levee.geojson").write_text(json.dumps(g))
    return out / "terrain.tif", out / "levee.geojson"


def _table(tmp_path, way, changes):
    d = tmp_path / way
    d.mkdir(parents=True, exist_ok=True)
    tif, geo = (SITE / "terrain.tif", SITE / "levee.geojson") if way == "south" else _mirrored(d / "terrain")
    text = scenario_with((SITE / "site.toml").read_text(), {"site.terrain": str(tif), "site.levee": str(geo), **changes})
    p = d / "scenario.toml"
    p.write_text(text)
    return p


def test_flow_sign_is_positive_towards_a_polder_at_plus_y():
    assert flow_sign(-1.0) == 1.0 and flow_sign(1.0) == -1.0


@pytest.fixture(scope="module")
def open_breach(tmp_path_factory):
    """The open breach of both sites at 2 m: (setup, snapshot) by flood side."""
    tmp = tmp_path_factory.mktemp("open")
    out = {}
    for way in ("south", "north"):
        s = closure_setup(load_scenario(_table(tmp, way, {"hydro.resolution": "2 m"})))
        out[way] = (s, s.solver.solve(s.domain))
    return out


def test_the_mirror_is_the_same_breach_with_the_flood_on_the_other_side(open_breach):
    (s, snap), (m, msnap) = open_breach["south"], open_breach["north"]
    assert s.metadata["site"]["flood_side"].startswith("right") and m.metadata["site"]["flood_side"].startswith("left")
    # independent of the sign rule: the grid's own +y discharge is the same flow mirrored
    q_s = snapshot_discharge(snap, s.breach_x, s.levee_y)
    q_n = snapshot_discharge(msnap, m.breach_x, m.levee_y)
    assert q_s > 30.0
    assert q_n == pytest.approx(-q_s, rel=1e-9)


def test_section_discharge_of_a_setup_is_positive_both_ways(open_breach):
    q = {w: section_discharge(snap, s.breach_x, s.levee_y, s.flow_sign) for w, (s, snap) in open_breach.items()}
    assert q["south"] > 30.0
    assert q["north"] == pytest.approx(q["south"], rel=1e-9)


def test_a_run_reports_the_same_positive_discharge_and_calibrates_its_weir_both_ways(tmp_path):
    got = {}
    for way in ("south", "north"):
        path = _table(tmp_path, way, RUN)
        run = tmp_path / way / "member" / "closure"
        result = run_closure(path, run)  # what `breachflow run` prints
        # the ensemble member (the atlas's detailed tier) reads the finished run back
        member = MemberScenario(key=way, number=0, table=tomllib.loads(path.read_text()), values={}, values_si={},
                                paths={}, path=path)
        res = ClosureRunner().run(member, tmp_path / way / "member", seed=1)
        man = json.loads((run / "manifest.json").read_text())
        with xr.open_mfdataset(str(run / "cycle_*.nc"), decode_times=False) as ds:
            cf = ds["breach_discharge"].values.astype(float)
            polder = ds["polder_level"].values.astype(float)
            assert ds["breach_discharge"].attrs["units"] in ("m3 s-1", "m3/s", "m^3/s", "m**3/s")
        got[way] = dict(open=man["metadata"]["initial"]["breach_discharge"], cf=cf, polder=polder,
                        member_open=res["initial_breach_discharge"].to("m**3/s").magnitude,
                        member_final=res["final_breach_discharge"].to("m**3/s").magnitude,
                        calibration=man["metadata"]["timeline_start"]["weir_calibration"],
                        start=man["metadata"]["timeline_start"], result=result,
                        rows=dict(result.table_rows()))
    s, n = got["south"], got["north"]
    # the open breach at the start: positive, the same both ways (the mirror is exact up to round-off)
    assert s["open"] > 10.0
    assert n["open"] == pytest.approx(s["open"], rel=1e-6)
    assert n["member_open"] == pytest.approx(s["open"], rel=1e-6) and s["member_open"] == pytest.approx(s["open"], rel=1e-12)
    # the run's result and its printed table
    for g in (s, n):
        r = g["result"]
        assert r.open_breach_discharge == pytest.approx(g["open"], rel=1e-12)
        assert r.final_discharge == pytest.approx(g["cf"][-1], rel=1e-12) and r.final_discharge > 0
        assert g["rows"]["breach discharge at the end (seepage)"].startswith(f"{r.final_discharge:.2f} m³/s")
    assert n["rows"]["breach discharge at the end (seepage)"] == s["rows"]["breach discharge at the end (seepage)"]
    # the cycle files' CF variable and the member result after the last cycle
    assert cf_ok(s["cf"]) and cf_ok(n["cf"])
    np.testing.assert_allclose(n["cf"], s["cf"], rtol=1e-6)
    assert n["member_final"] == pytest.approx(s["member_final"], rel=1e-6) and s["member_final"] > 0
    # the weir was calibrated on the flow model both ways: the coefficient moved off the ideal weir's to the
    # ratio of the model's discharge to the weir's, and the same way on both sides
    for g in (s, n):
        steps = g["calibration"]
        assert steps and steps[0]["model_discharge"] > 0
        assert len(steps) >= 2 and steps[-1]["weir_coefficient"] != pytest.approx(IDEAL_WEIR, rel=1e-3)
        assert steps[1]["weir_coefficient"] == pytest.approx(
            steps[0]["weir_coefficient"] * steps[0]["model_discharge"] / steps[0]["weir_discharge"], rel=1e-9)
    assert n["calibration"][-1]["weir_coefficient"] == pytest.approx(s["calibration"][-1]["weir_coefficient"], rel=1e-6)
    # the polder fills (it does not drain) before the start and over the cycle, the same both ways
    for g in (s, n):
        assert g["start"]["polder_level"] > g["start"]["prestart"][0]["polder_level"]
        assert np.all(g["polder"] > g["start"]["polder_level"])
    assert n["start"]["polder_level"] == pytest.approx(s["start"]["polder_level"], rel=1e-9)
    np.testing.assert_allclose(n["polder"], s["polder"], rtol=1e-9)


def cf_ok(q):
    """One finite, positive discharge per cycle."""
    return q.size >= 1 and np.all(np.isfinite(q)) and np.all(q > 0)


def _seal_case(flip: bool):
    """A 4 x 12 strip of 1 m cells: walls in the outer columns, a rock pile (stones of 1 m, porosity 0.4, 6 m
    high) across the first of the two open columns in rows 4-7 (the second left open, so that the seal does
    not cut the flood off from the polder and the flow model is re-solved: here it returns this field), the
    flood at 5 m on the low-y side and the polder at 4 m on the other (bed 0), 3 m³/s through the breach in
    the flow model towards the polder; *flip*: the same mirrored north-south (the flood on the high-y side)."""
    import types

    import xarray as xr

    from breachflow.materials.seal import Grading
    from breachflow.swe.porous import PorousPile

    ny, nx = 12, 4
    y, x = np.arange(ny) + 0.5, np.arange(nx) + 0.5
    height = np.zeros((ny, nx))
    height[4:8, 1] = 6.0
    eta = np.where(y[:, None] < 6.0, 5.0, 4.0) * np.ones((ny, nx))
    wall = np.zeros((ny, nx), bool)
    wall[:, [0, 3]] = True
    hv = np.where(wall, 0.0, 1.5)  # 1.5 m²/s in each of the 2 open columns: 3 m³/s towards +y
    if flip:
        height, eta, wall, hv = height[::-1], eta[::-1], wall[::-1], -hv[::-1]
    depth = np.where(wall, 0.0, eta)
    ds = xr.Dataset({"water_surface": (("y", "x"), eta), "depth": (("y", "x"), depth),
                     "v": (("y", "x"), np.where(depth > 0, hv / np.where(depth > 0, depth, 1.0), 0.0)),
                     "u": (("y", "x"), np.zeros((ny, nx))), "obstacle": (("y", "x"), wall)},
                    coords={"x": x, "y": y}, attrs={"steady_state": 1})
    pile = PorousPile.build(height, np.full(height.shape, 0.4), np.full(height.shape, 1.0))
    crit = types.SimpleNamespace(seal_layers=[Grading("sand", 0.004, 0.005, 0.006, porosity=0.35)],
                                 max_seal_thickness=1.0, pump_capacity=0.0, threshold=1e6, area=1e6,
                                 seal_leakage="series", law="ergun", filter_thickness=0.1, seal_growth=2.0)
    return ds, pile, crit, y, x, wall


@pytest.mark.parametrize("flip", [False, True])
def test_seal_leakage_adds_the_flow_models_discharge_and_the_seepage_the_same_way_round(flip):
    from breachflow.cycle.sealing import seal_dam

    ds, pile, crit, y, x, wall = _seal_case(flip)
    res = seal_dam(lambda p, initial, block: ds, pile, ds, crit, breach_x=(0.9, 3.1), levee_y=6.0, y=y, x=x,
                   flood_level=5.0, bed=np.zeros(ds["depth"].shape), obstacle=wall,
                   flow_sign=-1.0 if flip else 1.0)
    step = res.steps[0]
    # by hand: the seal starts at a quarter of max_seal_thickness (0.25 m of sand), the rock takes the rest of
    # the 4 m pile; in its one column q = h 2H / (A + sqrt(A^2 + 4 B H)), H = 1 m, h = 5 m (Ergun 1952, written out)
    nu, g = 1.0e-6, 9.81
    ergun = lambda n, d: (150 * nu * (1 - n) ** 2 / (g * n ** 3 * d ** 2), 1.75 * (1 - n) / (g * n ** 3 * d))
    (a_s, b_s), (a_r, b_r) = ergun(0.35, 0.005), ergun(0.4, 1.0)
    A, B = 0.25 * a_s + 3.75 * a_r, 0.25 * b_s + 3.75 * b_r
    q_series = 5.0 * 2 * 1.0 / (A + np.sqrt(A * A + 4 * B * 1.0))
    assert step.flow_model_leakage == pytest.approx(3.0, rel=1e-12)
    assert step.series_seepage == pytest.approx(q_series, rel=1e-9)
    assert step.leakage == pytest.approx(3.0 + q_series, rel=1e-9)
