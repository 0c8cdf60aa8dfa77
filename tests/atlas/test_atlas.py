"""The breach atlas: candidate locations, levee sections read off the terrain, the screening figures against
independent arithmetic, and the atlas run (dask, resume, outputs with the CRS)."""
from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.atlas import load_district, locate, run_atlas, screen
from breachflow.atlas.config import parse_district
from breachflow.atlas.locations import chainages, cross_section
from breachflow.errors import BreachflowError
from breachflow.site.geometry import LeveeLine
from breachflow.site.terrain import Terrain

ROOT = Path(__file__).resolve().parents[2]
DISTRICT = ROOT / "examples" / "district"


def _make_district():
    spec = importlib.util.spec_from_file_location("make_district", DISTRICT / "make_district.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_district"] = mod
    spec.loader.exec_module(mod)
    return mod


# ------------------------------------------------------------------------------------------ locations
def test_chainages_spacing_margin_and_user_points():
    s, user = chainages(1000.0, 200.0, points=[333.0], margin=100.0)
    # 800 m usable from 100 to 900 m in 4 reaches of 200 m: centres 200, 400, 600, 800, plus the user's point
    assert np.allclose(s, [200.0, 333.0, 400.0, 600.0, 800.0])
    assert user.tolist() == [False, True, False, False, False]
    with pytest.raises(BreachflowError, match="beyond the levee line"):
        chainages(1000.0, 200.0, points=[1200.0])


def _trapezoid_terrain(angle_deg: float, *, crest=6.0, toe_flood=1.0, toe_land=0.0, crown=6.0, slope=3.0,
                       pixel=0.5):
    """An analytic levee (crown *crown* m at *crest*, slopes 1V:*slope*H) along a straight line at *angle_deg*,
    flood ground *toe_flood* left of the line, polder ground *toe_land* right of it."""
    a = math.radians(angle_deg)
    t = np.array([math.cos(a), math.sin(a)])
    n = np.array([-t[1], t[0]])
    x = np.arange(-300.0, 300.0, pixel) + pixel / 2
    y = np.arange(-300.0, 300.0, pixel) + pixel / 2
    X, Y = np.meshgrid(x, y)
    d = X * n[0] + Y * n[1]
    half = crown / 2
    z = np.where(d >= 0, np.maximum(crest - np.maximum(d - half, 0) / slope, toe_flood),
                 np.maximum(crest - np.maximum(-d - half, 0) / slope, toe_land))
    line = LeveeLine(np.array([-250.0 * t, 250.0 * t]), None, "analytic")
    return Terrain(x=x, y=y, z=z, crs_wkt=None, path=Path("analytic")), line


@pytest.mark.parametrize("angle", [0.0, 33.0, 121.0])
def test_cross_section_of_an_analytic_levee(angle):
    terrain, line = _trapezoid_terrain(angle)
    sec = cross_section(line, terrain, 250.0, "left")
    assert sec["crest"] == pytest.approx(6.0, abs=0.01)
    assert sec["protected_ground"] == pytest.approx(0.0, abs=0.02)
    assert sec["flood_ground"] == pytest.approx(1.0, abs=0.02)
    assert sec["crown_width"] == pytest.approx(6.0, abs=1.01)      # 1 m profile step
    # toes: crown edge + height x slope (land: 3 + 6 x 3 = 21 m; flood: 3 + 5 x 3 = 18 m)
    assert sec["toe_protected"] == pytest.approx(21.0, abs=1.5)
    assert sec["toe_flood"] == pytest.approx(18.0, abs=1.5)
    assert sec["protected_slope"] == pytest.approx(3.0, rel=0.15)
    # the flood side is the caller's choice: swapping it swaps the grounds
    other = cross_section(line, terrain, 250.0, "right")
    assert other["protected_ground"] == pytest.approx(1.0, abs=0.02)


# ------------------------------------------------------------------------------------------ screening
@pytest.fixture(scope="module")
def small_district(tmp_path_factory):
    """A 1.6 km levee of the example generator (4 m pixels), written once."""
    out = tmp_path_factory.mktemp("district")
    _make_district().write(out, length=1600.0)
    return out


def _district(folder: Path, *, flow="weir", spacing="400 m"):
    p = folder / f"district_{flow}_{spacing.replace(' ', '')}.toml"
    p.write_text(_make_district().district_toml(folder / "terrain.tif", folder / "levee.geojson", flow=flow,
                                                spacing=spacing))
    return p


def test_weir_screening_against_independent_arithmetic(small_district):
    d = load_district(_district(small_district))
    from breachflow.atlas.locations import load_inputs as _inputs

    terrain, levee = _inputs(str(d.terrain), str(d.levee), None, None)
    loc = locate(levee, terrain, spacing=d.spacing, margin=d.margin)[1]
    r = screen(loc, d, terrain=terrain, levee=levee)
    h = 5.0 - loc.protected_ground
    assert r["head_m"] == pytest.approx(h)
    B = 13.4 * 12.0 ** 0.51                               # Verheij clay at 12 h (below the 2.5 h + 54.9 cap)
    assert B < 2.5 * h + 54.9
    assert r["breach_length_m"] == pytest.approx(B, rel=1e-9)
    C = 3.1 * 0.3048 ** 0.5                               # 3.1 ft^0.5/s in m^0.5/s
    Q = C * B * h ** 1.5                                  # vertical breach walls
    assert r["open_discharge_m3s"] == pytest.approx(Q, rel=1e-9)
    assert r["gap_speed_ms"] == pytest.approx(Q / (B * 2.0 / 3.0 * h), rel=1e-9)
    # closure window, linear flood falling 1 cm/h from h, polder rising at (Q - Qp) / A:
    rate = (Q - 5.0) / 12000e4                             # m/s
    t_inund = 1.0 / rate
    fall = 0.01 / 3600.0
    t_bal = h / (rate + fall)                             # polder level meets the falling flood
    assert r["inundation_time_h"] == pytest.approx(t_inund / 3600.0, rel=1e-6)
    assert r["balance_time_h"] == pytest.approx(t_bal / 3600.0, rel=1e-6)
    assert r["closure_window_h"] == pytest.approx(min(t_inund, t_bal) / 3600.0, rel=1e-6)
    # stone: Izbash exposed u^2 / (2 g Delta 0.86^2) unless Shields needs more; tonnage of a trapezoid dam
    u = r["gap_speed_ms"]
    D_izbash = u ** 2 / (2 * 9.81 * 1.65 * 0.86 ** 2)
    assert r["stone_size_m"] >= D_izbash * (1 - 1e-9)
    D = r["stone_size_m"]
    H = loc.levee_height
    b, m = max(3 * D, 1.0), 1.5
    V = b * B * H + m * B * H ** 2                        # crest b, side slopes 1.5, vertical breach walls
    assert r["tonnage_t"] == pytest.approx(0.6 * V * 2.65, rel=1e-9)
    # methods: mobilisation + the work (tonnage / capacity) on the calendar of the working hours, 16 h a day for
    # the trucks (whole days of 24 h, then the rest of the work); the fastest one that fits the window
    barge = 24.0 + r["tonnage_t"] / 1000.0
    work = r["tonnage_t"] / 350.0
    days, rest = divmod(work, 16.0)
    trucks = 12.0 + days * 24.0 + rest
    assert r["duration_h_split_barge"] == pytest.approx(barge, rel=1e-9)
    assert r["duration_h_end_dumping"] == pytest.approx(trucks, rel=1e-9)
    window = r["closure_window_h"]
    fits = {"split_barge": 12.0 + barge <= window, "end_dumping": 12.0 + trucks <= window}
    assert r["feasible"] == any(fits.values())
    want = min((n for n in fits if fits[n] or not any(fits.values())),
               key=lambda n: {"split_barge": barge, "end_dumping": trucks}[n])
    assert r["method"] == want


def test_no_head_is_not_at_risk(small_district):
    text = _district(small_district).read_text().replace('level = "5.0 m"', 'level = "-2.0 m"')
    d = parse_district(text, small_district / "low.toml")
    from breachflow.atlas.locations import load_inputs as _inputs

    terrain, levee = _inputs(str(d.terrain), str(d.levee), None, None)
    r = screen(locate(levee, terrain, spacing=d.spacing, margin=d.margin)[0], d, terrain=terrain, levee=levee)
    assert r["status"] == "not at risk" and not r["at_risk"] and math.isnan(r["tonnage_t"])


@pytest.mark.parametrize("change, match", [
    (('capacity = "1000 t/h"', 'capacity = "1000 m"'), "capacity"),
    (('growth = "verheij_clay"', 'growth = "verheij_clai"'), "unknown growth equation"),
    (('flow = "weir"', 'flow = "lbm"'), "unknown flow model"),
    (('spacing = "400 m"', 'spacing = "400 kg"'), "spacing"),
    (('working_hours = "16 h"', 'working_hours = "30 h"'), "per day"),
    (('[methods.end_dumping]\ncapacity = "350 t/h"', '[methods.catapult]'), "not a delivery method"),
    (('[polder]', '[poldr]'), "unknown section"),
    (('[polder]', '[detailed]\nreplicates = 1\n\n[polder]'), "replicates"),
])
def test_bad_district_files_name_the_key(small_district, change, match):
    text = _district(small_district).read_text().replace(*change)
    with pytest.raises(BreachflowError, match=match) as exc:
        parse_district(text, small_district / "bad.toml")
    assert "bad.toml" in str(exc.value)


# ------------------------------------------------------------------------------------------ the run
@pytest.fixture(scope="module")
def atlas_runs(small_district, tmp_path_factory):
    """The small district with the embedded solver, on a local cluster of 2 workers and of 1 worker."""
    from distributed import Client, LocalCluster

    path = _district(small_district, flow="swe", spacing="300 m")
    runs = {}
    for n in (2, 1):
        out = tmp_path_factory.mktemp(f"atlas{n}")
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            runs[n] = (out, run_atlas(path, out, client=client, progress=False))
    return path, runs


def test_results_do_not_depend_on_the_number_of_workers(atlas_runs):
    _, runs = atlas_runs
    a, b = runs[2][1], runs[1][1]
    assert a.sizes["location"] == 4
    for v in a.data_vars:
        if v == "solve_cpu_s":
            continue
        xr.testing.assert_identical(a[v], b[v])
    assert np.all(np.isfinite(a.open_discharge_m3s.values)) and np.all(a.open_discharge_m3s.values > 0)


def test_outputs_carry_the_crs_and_open_in_gis_tools(atlas_runs):
    import pyogrio
    from pyproj import CRS

    _, runs = atlas_runs
    out, ds = runs[2]
    info = pyogrio.read_info(out / "atlas.gpkg", layer="breach_atlas")
    assert info["features"] == 4 and info["geometry_type"] == "LineString"
    assert CRS.from_user_input(info["crs"]).to_epsg() == 26915
    for f in ("breach_chainage", "closure_window_h", "breach_length_m", "open_discharge_m3s", "stone_size_m",
              "tonnage_t", "p_closure", "method", "feasibility"):
        assert f in info["fields"]
    _, _, geoms, fields = pyogrio.raw.read(out / "atlas.gpkg", layer="breach_atlas")
    i = list(info["fields"]).index("tonnage_t")
    assert np.allclose(fields[i].astype(float), ds.tonnage_t.values, equal_nan=True)
    nc = xr.open_dataset(out / "atlas.nc")
    assert CRS.from_wkt(nc.crs.attrs["crs_wkt"]).to_epsg() == 26915
    assert nc.attrs["featureType"] == "point"
    assert (out / "atlas.png").stat().st_size > 10_000


def _map_parts(fig):
    """The map axes, the colour bars' axes by label, and the map's levee reaches as (linewidth, RGBA)."""
    from matplotlib.colors import to_rgba

    axes = [a for a in fig.axes if a.get_xlabel() == "easting (m)"]
    assert len(axes) == 1
    ax = axes[0]
    bars = {a.get_ylabel(): a for a in fig.axes if a is not ax}
    reaches = [(ln.get_linewidth(), to_rgba(ln.get_color())) for ln in ax.lines if ln.get_linewidth() >= 3]
    return ax, bars, reaches


@pytest.mark.parametrize("p_at", [{}, {0: 0.0, 2: 1.0}, {1: 2 / 3, 2: 1 / 3, 3: 0.5}])
def test_map_colours_simulated_reaches_by_p_closure_and_shows_the_district_in_full(atlas_runs, p_at):
    """The map: the extent holds the whole levee line, coordinates are written in full (no offset or
    scientific notation), the title lies inside the figure; reaches where the closure was simulated are drawn
    in the P(closure) colour map (darker for a larger P, with a 0-1 colour bar), the other reaches in the
    screening class colours under a legend titled "screening only"."""
    from matplotlib.colors import to_rgba

    from breachflow.atlas.execute import plan
    from breachflow.atlas.locations import load_inputs
    from breachflow.atlas.outputs import CLASSES, reach_lines, render_map

    path, runs = atlas_runs
    ds = runs[2][1].copy()
    district, locations = plan(path)
    terrain, levee = load_inputs(str(district.terrain), str(district.levee), None, None)
    n = ds.sizes["location"]
    p = np.full(n, np.nan)
    for i, v in p_at.items():
        p[i] = v
    ds["p_closure"] = ("location", p)
    fig = render_map(ds, terrain, reach_lines(locations, levee), title="a district: closure feasibility and P(closure)")
    fig.canvas.draw()
    ax, bars, reaches = _map_parts(fig)
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    xs, ys = levee.coords[:, 0], levee.coords[:, 1]
    assert x0 <= xs.min() and xs.max() <= x1 and y0 <= ys.min() and ys.max() <= y1
    # coordinates in full: no offset text, tick labels are the eastings / northings themselves
    assert ax.xaxis.get_offset_text().get_text() == "" and ax.yaxis.get_offset_text().get_text() == ""
    for labels, k in ((ax.get_xticklabels(), 0), (ax.get_yticklabels(), 1)):
        shown = [(float(t.get_text().replace(",", "")), t.get_position()[k]) for t in labels if t.get_text()]
        assert len(shown) >= 3 and all(text == pos and text > 1e5 for text, pos in shown)
    # the title is inside the figure
    fb, tb = fig.bbox, ax.title.get_window_extent()
    assert ax.title.get_text() and fb.x0 <= tb.x0 and tb.x1 <= fb.x1 and tb.y1 <= fb.y1
    assert "ground elevation (m)" in bars
    legend = ax.get_legend()
    assert legend is not None
    simulated = [i for i in range(n) if np.isfinite(p[i])]
    assert len(reaches) == n
    names = list(CLASSES)
    if simulated:
        assert "screening only" in legend.get_title().get_text()
        bar = [a for label, a in bars.items() if "P(closure)" in label]
        assert len(bar) == 1
        assert bar[0].get_ylim() == pytest.approx((0.0, 1.0))
        assert any("closure simulated" in t.get_text() for t in legend.get_texts())
        wide = [reaches[i] for i in simulated]
        assert all(w > max(r[0] for k, r in enumerate(reaches) if k not in simulated) for w, _ in wide)
        # darker for a larger P (the sum of R, G, B falls), and no class colour is used for them
        order = np.argsort([p[i] for i in simulated])
        brightness = [sum(wide[k][1][:3]) for k in order]
        assert all(a > b for a, b in zip(brightness, brightness[1:]))
        assert not {c for _, c in wide} & {to_rgba(c) for c in CLASSES.values()}
    else:
        assert not any("P(closure)" in label for label in bars)
        assert "screening" in legend.get_title().get_text()
    for i in range(n):
        if i not in simulated:
            assert reaches[i][1] == to_rgba(CLASSES[names[int(ds.feasibility.values[i])]])
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_resume_reuses_records_and_a_changed_district_recomputes(atlas_runs, tmp_path):
    from distributed import Client, LocalCluster

    path, runs = atlas_runs
    out, ds = runs[1]
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "locations").iterdir()}
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        again = run_atlas(path, out, client=client, progress=False)
        assert {p.name: p.stat().st_mtime_ns for p in (out / "locations").iterdir()} == stamps
        xr.testing.assert_identical(again.drop_vars("solve_cpu_s"), ds.drop_vars("solve_cpu_s"))
        changed = tmp_path / "changed.toml"
        changed.write_text(path.read_text().replace('area = "12000 ha"', 'area = "6000 ha"'))
        other = run_atlas(changed, out, client=client, progress=False)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "locations").iterdir()} != stamps
    assert np.all(other.closure_window_h.values < ds.closure_window_h.values)  # a smaller polder fills sooner
    rec = json.loads((out / "locations" / "0000.json").read_text())
    assert rec["result"]["status"] == "ok"


@pytest.fixture
def external_cluster(tmp_path):
    """A dask scheduler and 2 workers started as separate processes on 127.0.0.1 (as on a cluster's nodes),
    found through a scheduler file."""
    import os
    import subprocess
    import time

    sched_file = tmp_path / "scheduler.json"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        t0 = time.monotonic()
        while not sched_file.exists() and time.monotonic() - t0 < 60:
            time.sleep(0.2)
        assert sched_file.exists(), "the dask scheduler did not start within 60 s"
        for _ in range(2):
            procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file",
                                           str(sched_file), "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                           "--host", "127.0.0.1"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        from distributed import Client

        with Client(scheduler_file=str(sched_file), timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        yield sched_file
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


def test_an_external_scheduler_gives_the_local_cluster_results(atlas_runs, external_cluster, tmp_path):
    """The same atlas from a scheduler and workers started by hand (scheduler file, then address)."""
    path, runs = atlas_runs
    local = runs[2][1]
    by_file = run_atlas(path, tmp_path / "by_file", scheduler=str(external_cluster), progress=False)
    address = json.loads(external_cluster.read_text())["address"]
    assert address.startswith("tcp://127.0.0.1:")
    by_address = run_atlas(path, tmp_path / "by_address", scheduler=address, progress=False)
    for ds in (by_file, by_address):
        xr.testing.assert_identical(ds.drop_vars("solve_cpu_s"), local.drop_vars("solve_cpu_s"))


def test_a_lost_workers_locations_are_run_again(small_district, external_cluster, tmp_path):
    """Kill a worker (SIGKILL) while it screens a location: the scheduler runs its tasks again elsewhere and the
    atlas completes with every location, equal to a run without the loss."""
    import os
    import signal
    import threading
    import time

    from distributed import Client

    path = _district(small_district, flow="swe", spacing="150 m")
    with Client(scheduler_file=str(external_cluster), timeout=60) as client:
        reference = run_atlas(path, tmp_path / "reference", client=client, progress=False)
        pids = client.run(os.getpid)
        result, killed = {}, {}

        def run():
            result["ds"] = run_atlas(path, tmp_path / "lossy", client=client, progress=False)

        th = threading.Thread(target=run)
        th.start()
        t0 = time.monotonic()
        while not killed and th.is_alive() and time.monotonic() - t0 < 120:
            busy = {w: ts for w, ts in client.processing().items() if any(str(t).startswith("atlas-screen") for t in ts)}
            if busy:
                victim = sorted(busy)[0]
                os.kill(pids[victim], signal.SIGKILL)
                killed[victim] = list(busy[victim])
            time.sleep(0.05)
        th.join(timeout=600)
    assert killed, "no worker was caught screening a location"
    ds = result["ds"]
    assert ds.sizes["location"] == reference.sizes["location"] >= 8
    assert all(json.loads(p.read_text())["result"]["status"] == "ok" for p in (tmp_path / "lossy" / "locations").iterdir())
    xr.testing.assert_identical(ds.drop_vars("solve_cpu_s"), reference.drop_vars("solve_cpu_s"))


# ------------------------------------------------------------------------------------------ detailed tier
def test_detailed_tier_spec_takes_the_worst_locations_with_their_screening_figures(atlas_runs):
    from breachflow.atlas.detailed import choose, ensemble_table
    from breachflow.atlas.execute import plan
    from breachflow.ensemble.spec import parse_spec
    from breachflow.scenario import parse_scenario
    from breachflow.scenario.toml import dump_toml

    path, runs = atlas_runs
    ds = runs[2][1]
    district, locations = plan(path)
    chosen = choose(ds, 2)
    margins = ds.margin_h.values
    assert list(chosen) == list(np.argsort(margins, kind="stable")[:2])
    assert choose(ds, "all") == list(np.argsort(margins, kind="stable"))
    template = {"hydro": {"resolution": "8 m"}, "criteria": {"max_cycles": 2}}
    spec = parse_spec(dump_toml(ensemble_table(district, ds, locations, chosen, replicates=3, template=template)),
                      path=path.parent / "detailed.toml")
    members = spec.members()
    assert len(members) == 2 * 3 and spec.replicates == 3
    by_dim = {p.dotted: p.name for p in spec.parameters}
    for k, i in enumerate(chosen):
        m = members[3 * k]
        assert float(m.values[by_dim["site.breach_at"]].split()[0]) == pytest.approx(locations[i].chainage, abs=0.01)
        assert float(m.values[by_dim["placement.diameter"]].split()[0]) == pytest.approx(float(ds.stone_size_m[i]),
                                                                                         abs=0.006)
        q = (float(m.values[by_dim["breach.mean_velocity"]].split()[0]) * float(ds.head_m[i])
             * float(m.values[by_dim["breach.length"]].split()[0]))
        assert q == pytest.approx(float(ds.open_discharge_m3s[i]), rel=2e-4)
    from breachflow.scenario.toml import dump_toml as dump

    scenario = parse_scenario(dump(spec.member_table(members[0])), path=path.parent / "member.toml")
    assert {"site", "hydro", "criteria", "flood", "polder", "breach"} <= set(scenario.sections)
    with pytest.raises(BreachflowError, match="must not set \\[site\\]"):
        ensemble_table(district, ds, locations, chosen, replicates=3, template={"site": {}})


def test_detailed_tier_members_find_the_terrain_of_a_district_given_by_a_relative_path(atlas_runs, small_district,
                                                                                     monkeypatch, tmp_path):
    """A district file named relative to the working directory, with its terrain and levee relative to it: the
    members' scenarios (written in their own directories) still find both."""
    from breachflow.atlas.detailed import ensemble_table
    from breachflow.atlas.execute import plan
    from breachflow.ensemble.spec import parse_spec
    from breachflow.scenario import parse_scenario
    from breachflow.scenario.toml import dump_toml

    path, runs = atlas_runs
    text = path.read_text().replace(str(small_district / "terrain.tif"), "terrain.tif").replace(
        str(small_district / "levee.geojson"), "levee.geojson")
    assert 'terrain = "terrain.tif"' in text
    (small_district / "relative.toml").write_text(text)
    monkeypatch.chdir(small_district.parent)
    district, locations = plan(Path(small_district.name) / "relative.toml")
    table = ensemble_table(district, runs[2][1], locations, [0], replicates=2, template={})
    assert Path(table["site"]["terrain"]).is_absolute() and Path(table["site"]["terrain"]).is_file()
    spec = parse_spec(dump_toml(table), path=tmp_path / "detailed.toml")
    member_dir = tmp_path / "detailed" / "members" / "m0"
    member_dir.mkdir(parents=True)
    scenario = parse_scenario(dump_toml(spec.member_table(spec.members()[0])), path=member_dir / "scenario.toml")
    assert "site" in scenario.sections


@pytest.mark.slow
def test_detailed_tier_runs_the_closure_at_the_worst_location(small_district, tmp_path):
    """The whole atlas with a [detailed] table: P(closure) and the tonnage range land in the layer."""
    import pyogrio

    template = tmp_path / "closure.toml"
    template.write_text('[hydro]\nresolution = "8 m"\ntolerance = "2e-3 1/s"\n\n[placement]\nbatch = 20\n\n'
                        '[criteria]\nmax_cycles = 3\n')
    path = _district(small_district, flow="swe", spacing="400 m")
    text = path.read_text() + f'\n[detailed]\nworst = 1\nreplicates = 2\nscenario = "{template}"\n'
    path = tmp_path / "district.toml"
    path.write_text(text)
    ds = run_atlas(path, tmp_path / "out", workers=2, progress=False)
    worst = int(np.nanargmin(np.where(np.isfinite(ds.margin_h.values), ds.margin_h.values, np.inf)))
    p = ds.p_closure.values
    assert np.isfinite(p[worst]) and 0.0 <= p[worst] <= 1.0
    assert np.isnan(np.delete(p, worst)).all()
    assert ds.tonnage_detailed_t_median.values[worst] > 0
    info = pyogrio.read_info(tmp_path / "out" / "atlas.gpkg", layer="breach_atlas")
    assert "p_closure" in info["fields"]


def test_cli_atlas_follows_the_run_conventions(small_district, tmp_path):
    """`breachflow atlas`: writes its three outputs; a second run into the same --out is refused unless
    --resume (keeps the records) or --overwrite (computes again); errors name the district file's key.
    Piped output wraps at ``$COLUMNS`` when set (the CLI's convention), so the children get none."""
    import os
    import subprocess

    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    path = _district(small_district, flow="weir", spacing="400 m")
    out = tmp_path / "atlas"
    cmd = [sys.executable, "-m", "breachflow", "atlas", str(path), "--out", str(out), "--workers", "1"]
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    assert first.returncode == 0, first.stderr
    assert {"atlas.nc", "atlas.gpkg", "atlas.png"} <= {p.name for p in out.iterdir()}
    assert "screening locations" in first.stdout + first.stderr
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    assert again.returncode != 0 and "holds an atlas already" in again.stdout + again.stderr
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "locations").iterdir()}
    resumed = subprocess.run(cmd + ["--resume"], capture_output=True, text=True, timeout=600, env=env)
    assert resumed.returncode == 0 and "done earlier (resume)" in resumed.stdout + resumed.stderr
    assert {p.name: p.stat().st_mtime_ns for p in (out / "locations").iterdir()} == stamps
    redone = subprocess.run(cmd + ["--overwrite"], capture_output=True, text=True, timeout=600, env=env)
    assert redone.returncode == 0
    assert all(p.stat().st_mtime_ns > stamps[p.name] for p in (out / "locations").iterdir())
    bad = tmp_path / "bad.toml"
    bad.write_text(path.read_text().replace('spacing = "400 m"', 'spacing = "400 kg"'))
    err = subprocess.run(cmd[:4] + [str(bad), "--out", str(tmp_path / "x")], capture_output=True, text=True, timeout=600, env=env)
    assert err.returncode != 0 and "bad.toml" in err.stdout + err.stderr and "spacing" in err.stdout + err.stderr
    assert not (tmp_path / "x").exists()


def test_detailed_members_are_handed_out_largest_screening_tonnage_first():
    from breachflow.atlas.detailed import longest_first

    ds = xr.Dataset({"tonnage_t": ("location", [5000.0, np.nan, 9000.0, 7000.0, 9000.0])})
    # ties keep the screening's order (worst first); a location without tonnage goes last
    assert longest_first(ds, [0, 4, 1, 2, 3]) == [4, 2, 3, 0, 1]
    assert longest_first(ds, []) == []
