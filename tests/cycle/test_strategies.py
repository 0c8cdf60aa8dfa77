"""Placement strategies (issue 14): the registry, today's line/zone/list unchanged, the closure strategies
``vertical`` and ``horizontal`` on synthetic sills, the pile view, and resume of real runs."""
from pathlib import Path

import numpy as np
import pytest

from breachflow import InputError
from breachflow.cycle.placement import PlacementPlan
from breachflow.cycle.strategies import SPACING, PileView, placement_strategies
from breachflow.scenario.toml import scenario_with



def surface(x, y):
    return np.full_like(np.asarray(x, float), 3.0)


def _old_release_xy(plan, g, seed):
    """Release points of line/zone/list computed independently, as the line/zone/list rules define them before any registry."""
    rng = np.random.default_rng([int(seed), int(g)])
    n = plan.batch
    d = rng.uniform(plan.diameter[0], plan.diameter[1], n) if plan.diameter[1] > plan.diameter[0] else np.full(n, plan.diameter[0])
    if plan.density[1] > plan.density[0]:
        rng.uniform(plan.density[0], plan.density[1], n)  # the densities are drawn before the positions
    k = (g - 1) * n + np.arange(n)
    if plan.positions == "line":
        f = np.mod(0.5 + k * 0.6180339887498949, 1.0)
        xy = np.asarray(plan.start)[None, :] + f[:, None] * (np.asarray(plan.stop) - np.asarray(plan.start))[None, :]
        return xy + rng.normal(0.0, 0.05 * d.mean(), (n, 2))
    if plan.positions == "zone":
        x0, x1, y0, y1 = plan.zone
        return np.column_stack([rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)])
    pts = np.asarray(plan.points, float)
    return pts[k % len(pts)]


@pytest.mark.parametrize("kw", [dict(positions="line", start=(-7.0, 1.0), stop=(6.0, -0.5)),
                                dict(positions="zone", zone=(-5.0, 4.0, -2.0, 3.0)),
                                dict(positions="list", points=[(0.0, 0.0), (2.0, 1.0), (-3.0, 0.5)])])
@pytest.mark.parametrize("density", [2650.0, (2400.0, 2800.0)])
def test_line_zone_list_place_what_they_placed_before_the_registry(kw, density):
    plan = PlacementPlan(diameter=(0.5, 0.9), density=density, batch=4, **kw)
    for g in (1, 2, 7):
        for seed in (0, 3, 11):
            got = plan.release(g, seed, surface).pos[:, :2]
            np.testing.assert_array_equal(got, _old_release_xy(plan, g, seed))


def test_registry_lists_the_strategies_and_refuses_unknown_names():
    assert {"line", "zone", "list", "vertical", "horizontal"} <= set(placement_strategies.available())
    with pytest.raises(InputError, match="vertical"):
        PlacementPlan(positions="diagonal")
    with pytest.raises(InputError, match="needs the pile state"):
        PlacementPlan(positions="vertical", start=(-4.0, 0.0), stop=(4.0, 0.0)).release(1, 0, surface)
    with pytest.raises(InputError, match="zero length"):
        PlacementPlan(positions="horizontal").check_inside((-10, 10), (-10, 10))


def _view(crest, length=10.0, level=3.0):
    crest = np.asarray(crest, float)
    return PileView(np.linspace(0.0, length, crest.size), crest, level)


def _plan(positions, batch, d=(1.8, 2.2), length=10.0):
    return PlacementPlan(diameter=d, batch=batch, positions=positions, start=(-0.5 * length, 0.0),
                         stop=(0.5 * length, 0.0))


@pytest.mark.parametrize("positions", ["vertical", "horizontal"])
@pytest.mark.parametrize("batch", [1, 3, 7, 20])
def test_release_points_stay_in_the_gap(positions, batch):
    """Whatever the sill and the seed: every release point lies on the gap line between its ends
    (x within start..stop) and within SPACING largest diameters across it."""
    rng = np.random.default_rng(7)
    plan = _plan(positions, batch)
    for trial in range(40):
        crest = np.maximum(rng.normal(1.5, 1.5, 41), 0.0)
        rel = plan.release(int(rng.integers(1, 30)), int(rng.integers(0, 1000)), surface, pile=_view(crest))
        assert np.all((rel.pos[:, 0] >= -5.0) & (rel.pos[:, 0] <= 5.0)), rel.pos
        assert np.all(np.abs(rel.pos[:, 1]) <= SPACING * 2.2 + 1e-12), rel.pos
        # never released into the pile: the sphere's bottom is above the sill at its point
        crest_there = np.interp(rel.pos[:, 0] + 5.0, np.linspace(0, 10, 41), crest)
        assert np.all(rel.pos[:, 2] - rel.radius >= np.maximum(crest_there, 3.0) + plan.release_height - 1e-9)


@pytest.mark.parametrize("dip", range(9))
def test_vertical_drops_on_the_lowest_part_of_the_sill(dip):
    """A sill one diameter high everywhere but one slot of the gap: a single mass goes to that slot,
    whichever it is; a dip anywhere else (off the slot grid) gets the mass into a slot overlapping it."""
    length = 20.0
    n_slots = int(np.floor(length / (SPACING * 2.0))) + 1  # 9 slots 2.5 m apart
    slot = length / (n_slots - 1)
    s = np.linspace(0.0, length, 161)
    plan = _plan("vertical", 1, d=2.0, length=length)
    centre = dip * slot
    crest = np.where(np.abs(s - centre) <= 0.5 * slot, 0.0, 2.0)
    for seed in range(5):
        x = plan.release(3, seed, surface, pile=PileView(s, crest, 3.0)).pos[0, 0] + 0.5 * length
        assert abs(x - centre) <= 0.3, (dip, x)
    for off_grid in np.linspace(0.3, length - 0.3, 23):
        crest = np.where(np.abs(s - off_grid) <= 1.0, 0.0, 2.0)
        x = plan.release(3, 1, surface, pile=PileView(s, crest, 3.0)).pos[0, 0] + 0.5 * length
        assert abs(x - off_grid) <= 0.5 * slot + 1.0 + 0.3, (off_grid, x)


def test_vertical_spreads_a_batch_over_the_whole_gap_layer_by_layer():
    """On a flat sill a batch of as many masses as the gap has slots puts one in every slot (the layer
    covers the width); the next batch, with the first layer in place, is a second layer over the width
    again, not a tower: with one slot left low, it goes there first."""
    length = 23.0
    plan = _plan("vertical", 1, d=2.0, length=length)
    n_slots = int(np.floor(length / (SPACING * 2.0))) + 1
    plan.batch = n_slots
    s = np.linspace(0.0, length, 93)
    x = np.sort(plan.release(1, 4, surface, pile=PileView(s, np.zeros_like(s), 3.0)).pos[:, 0]) + 0.5 * length
    slot = length / (n_slots - 1)
    np.testing.assert_allclose(x, np.arange(n_slots) * slot, atol=0.35)
    # a first batch of 3 on a flat sill lands far apart (spread, not clustered)
    plan.batch = 3
    x3 = np.sort(plan.release(1, 4, surface, pile=PileView(s, np.zeros_like(s), 3.0)).pos[:, 0])
    assert np.min(np.diff(x3)) > 0.2 * length
    # layer one done except the slot around s = 7 slots: the next single mass fills it
    crest = np.full_like(s, 2.0)
    hole = 7 * slot
    crest[np.abs(s - hole) <= 0.5 * slot] = 0.0
    plan.batch = 1
    assert abs(plan.release(2, 0, surface, pile=PileView(s, crest, 3.0)).pos[0, 0] + 0.5 * length - hole) < 0.4


def test_horizontal_drops_at_both_heads_and_moves_inward_as_the_pile_grows():
    length = 30.0
    s = np.linspace(0.0, length, 61)
    plan = _plan("horizontal", 2, d=2.0, length=length)
    lefts, rights = [], []
    for a, b in [(0.0, 30.0), (4.0, 27.0), (9.0, 22.0), (13.0, 16.0)]:
        crest = np.where((s < a) | (s > b), 3.5, 1.0)  # the heads stand above the water (level 3 m)
        rel = plan.release(5, 2, surface, pile=PileView(s, crest, 3.0))
        xl, xr = rel.pos[:, 0] + 0.5 * length
        # the masses are at the heads: the first open point from each end
        open_ = s[crest < 3.0]
        assert abs(xl - open_[0]) < 0.4 and abs(xr - open_[-1]) < 0.4, (a, b, xl, xr)
        lefts.append(xl)
        rights.append(xr)
    assert np.all(np.diff(lefts) > 0) and np.all(np.diff(rights) < 0)
    # a batch of one alternates between the heads cycle after cycle
    plan.batch = 1
    crest = np.where((s < 6.0) | (s > 20.0), 3.5, 1.0)
    xs = [plan.release(g, 0, surface, pile=PileView(s, crest, 3.0)).pos[0, 0] + 0.5 * length for g in range(1, 7)]
    assert all(abs(x - 6.0) < 0.4 for x in xs[0::2]) and all(abs(x - 20.0) < 0.4 for x in xs[1::2]), xs
    # several masses on one side: rows across the line, then further in, never past the gap's middle
    plan.batch = 12
    rel = plan.release(1, 0, surface, pile=PileView(s, crest, 3.0))
    x = rel.pos[:, 0] + 0.5 * length
    assert np.all(x[0::2] <= 13.0 + 0.4) and np.all(x[1::2] >= 13.0 - 0.4)
    assert len(np.unique(np.round(rel.pos[0::2, 1] / 2.3))) == 3  # three rows across


def test_pile_view_of_a_sphere_on_a_flat_bed():
    """The crest along the gap line is the sphere's top z_c + r over its centre, the bed elsewhere, and
    masses farther than the band from the line are not part of the sill."""
    from breachflow.cycle.remap import pile_top

    x = np.arange(-10.0, 10.01, 0.5)
    y = np.arange(-6.0, 6.01, 0.5)
    bed = np.full((y.size, x.size), -1.0)
    pos = np.array([[2.0, 0.5, 0.0], [-4.0, 5.0, 0.5]])
    rad = np.array([1.0, 1.0])
    top = pile_top(x, y, bed, pos, rad, np.array([True, True]))
    view = PileView.from_grid(x, y, bed, top, (-8.0, 0.0), (8.0, 0.0), band=2.0, level=3.0)
    assert view.s[0] == 0.0 and view.s[-1] == pytest.approx(16.0)
    np.testing.assert_allclose(view.crest_at(10.0), 1.0)  # x = 2: the top of the first sphere
    far = np.abs(view.s - 4.0) <= 1.0  # x = -4: the second sphere is 5 m off the line
    np.testing.assert_allclose(view.crest[far], -1.0)
    np.testing.assert_allclose(view.crest[np.abs(view.s - 10.0) > 1.01], -1.0)


@pytest.mark.parametrize("cells", [0.5, 4.0])
def test_pile_view_from_the_masses_is_the_same_on_every_grid(cells):
    """Read from the masses, the sill over a flat bed (-1 m) is a sphere's top z_c + r wherever its silhouette
    covers the line (|s - s_c| <= r), the bed elsewhere, on a 0.5 m and a 4 m grid alike; a sphere farther than
    the band from the line and one that is not a member are not part of the sill."""
    x = np.arange(-10.0, 10.01, cells)
    y = np.arange(-6.0, 6.01, cells)
    bed = np.full((y.size, x.size), -1.0)
    pos = np.array([[2.0, 0.5, 0.0], [-4.0, 5.0, 0.5], [-1.0, 0.0, 4.0], [4.5, -0.5, 0.3]])
    rad = np.array([1.0, 1.0, 1.0, 0.5])
    view = PileView.from_masses(x, y, bed, pos, rad, np.array([True, True, False, True]), (-8.0, 0.0), (8.0, 0.0),
                                band=2.0, level=3.0)
    assert view.s[0] == 0.0 and view.s[-1] == pytest.approx(16.0) and np.diff(view.s).max() <= 0.05 + 1e-12
    x_of = view.s - 8.0
    np.testing.assert_allclose(view.crest[np.abs(x_of - 2.0) <= 1.0], 1.0)
    np.testing.assert_allclose(view.crest[np.abs(x_of - 4.5) <= 0.5], 0.8)
    np.testing.assert_allclose(view.crest[(np.abs(x_of - 2.0) > 1.0) & (np.abs(x_of - 4.5) > 0.5)], -1.0)


CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


class Crash(Exception):
    pass


def _same_files(a, b):
    import xarray as xr

    for group in (None, "convergence_history"):
        with xr.open_dataset(a, group=group) as da, xr.open_dataset(b, group=group) as db:
            assert set(da.variables) == set(db.variables)
            for name in da.variables:
                np.testing.assert_array_equal(da[name].values, db[name].values, err_msg=name)
            assert {k: str(v) for k, v in da.attrs.items() if k != "history"} == \
                   {k: str(v) for k, v in db.attrs.items() if k != "history"}


@pytest.mark.parametrize("positions", ["vertical", "horizontal"])
def test_closure_strategies_resume_bit_identically(tmp_path, positions):
    """A run crashed after cycle 2 and resumed writes cycle 3 exactly as an uninterrupted run: the pile
    the strategy reads is rebuilt from the restart record (masses rest after cycle 2, so it matters)."""
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun
    from breachflow.io import RunDirectory
    from breachflow.scenario.config import parse_scenario

    text = scenario_with(CI_CLOSURE, {"scenario.name": "ci strategies", "dem.max_time": "4 s", "placement.positions": positions,
                                       "placement.start": None, "placement.stop": None, "criteria.max_cycles": 3})

    def run(path, resume=False, progress=None):
        r = ClosureRun(closure_setup(parse_scenario(text)), path, text, resume=resume, progress=progress)
        r.run()
        return r

    full = run(tmp_path / "full")

    def crash(rep):
        if rep.cycle == 2:
            raise Crash()

    with pytest.raises(Crash):
        run(tmp_path / "resumed", progress=crash)
    rd = RunDirectory(tmp_path / "resumed")
    assert rd.completed_cycles() == [1, 2]
    assert rd.load_restart(2)["resting"].sum() >= 2  # a pile to read
    run(tmp_path / "resumed", resume=True)
    assert rd.completed_cycles() == [1, 2, 3]
    _same_files(full.rundir.cycle_path(3), rd.cycle_path(3))
    with __import__("xarray").open_dataset(rd.cycle_path(3)) as ds:
        assert ds.attrs["placement_strategy"] == positions
        placed = ds.particle_placed_cycle.values[0] > 0
        # the masses were released inside the breach (12 m, walls at x = +-6 m)
        assert np.all(np.abs(ds.particle_x.values[0][placed]) < 6.0 + 1.0)
    # the gap speeds are reported per cycle: finite, max >= mean >= 0
    for c in rd.manifest()["cycles"]:
        sm = c["summary"]
        assert sm["gap_max_speed"] >= sm["gap_mean_speed"] >= 0.0 and np.isfinite(sm["gap_max_speed"])


def test_gap_section_speeds_by_hand():
    """Max and depth-weighted mean speed over the open wet cells of the row nearest y in x_range."""
    import xarray as xr

    from breachflow.cycle.criteria import gap_section_speeds, section_discharge

    x = np.arange(-3.0, 3.01, 1.0)
    y = np.array([-1.0, 0.0, 1.0])
    h = np.tile([0.0, 1.0, 2.0, 2.0, 2.0, 1.0, 0.5], (3, 1))
    u = np.full((3, 7), 0.5)
    v = np.tile([0.0, 3.0, 4.0, 4.0, 9.0, 3.0, 1.0], (3, 1))
    obstacle = np.zeros((3, 7), np.int8)
    obstacle[1, 4] = 1  # a blocked cell in the gap: excluded
    ds = xr.Dataset({"depth": (("y", "x"), h), "u": (("y", "x"), u), "v": (("y", "x"), v),
                     "wet": (("y", "x"), (h > 0).astype("i1")), "obstacle": (("y", "x"), obstacle)},
                    coords={"x": x, "y": y})
    gmax, gmean = gap_section_speeds(ds, (-2.0, 2.0), 0.1)
    # open wet cells of row y = 0 with -2 <= x <= 2: x = -2, -1, 0, 2 (x = 1 blocked)
    sp = np.hypot(0.5, np.array([3.0, 4.0, 4.0, 3.0]))
    hh = np.array([1.0, 2.0, 2.0, 1.0])
    assert gmax == pytest.approx(np.hypot(0.5, 4.0))
    assert gmean == pytest.approx(np.sum(hh * sp) / np.sum(hh))
    assert section_discharge(ds, (-2.0, 2.0), 0.1) == pytest.approx(3 + 8 + 8 + 3)
    ds["obstacle"][:] = 1
    assert gap_section_speeds(ds, (-2.0, 2.0), 0.0) == (0.0, 0.0)
