"""``[closure] method`` over an ingested flow model (issue 30): its boundaries come from the model's own
result, so the flood and the polder are held frozen, but the operation time is the delivery method's,
from the tonnes placed and the capacity, and the run says plainly that the flood is held frozen."""
import json

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.frozen_timeline import FrozenFloodTimeline
from breachflow.cycle.main import run_closure
from breachflow.cycle.plan import plan_lines
from breachflow.errors import BreachflowWarning, InputError, ParseError
from breachflow.field.snapshot import grid_snapshot
from breachflow.scenario.config import parse_scenario

from .test_snapshot_frozen import BASE

TIMED = BASE + """method = "barge_crane"
start = "{start}"
capacity = "{capacity}"
[polder]
area = "300 ha"
"""


def _snapshot(tmp_path):
    """A still-water field at 3 m on the demo scene's grid with a 0.3 m/s current toward the polder."""
    sc = parse_scenario(BASE.replace('solver = "{solver}"', 'solver = "swe"').replace('snapshots = ["{snap}"]', ""))
    dom = closure_setup(sc).domain
    depth = np.maximum(3.0 - dom.bed, 0.0)
    path = tmp_path / "snap.nc"
    grid_snapshot(dom.x, dom.y, dom.bed, depth, np.zeros_like(depth), np.full_like(depth, 0.3)).to_netcdf(path)
    return path


def _placed_tonnes(run, g):
    """Tonnes released up to cycle *g*, from the particles of cycle *g*'s file (pi/6 D^3 rho)."""
    with xr.open_dataset(run / f"cycle_{g:04d}.nc", decode_times=False) as ds:
        placed = np.asarray(ds["particle_placed_cycle"].values).ravel()
        d = np.asarray(ds["particle_diameter"].values, float).ravel()
        rho = np.asarray(ds["particle_density"].values, float).ravel()
    sel = (placed >= 1) & (placed <= g)
    return float(np.sum(np.pi / 6.0 * d[sel] ** 3 * rho[sel])) / 1000.0


@pytest.mark.parametrize("start_h, capacity_t_h", [(0.0, 400.0), (30.0, 25.0)])
def test_ingested_model_runs_a_method_with_the_flood_held_frozen(tmp_path, start_h, capacity_t_h):
    snap = _snapshot(tmp_path)
    scen = tmp_path / "timed.toml"
    scen.write_text(TIMED.format(solver="snapshot_frozen", snap=snap, start=f"{start_h:g} h",
                                 capacity=f"{capacity_t_h:g} t/hr"))
    with pytest.warns(BreachflowWarning, match="does not respond to the pile"):
        setup = closure_setup(parse_scenario(scen.read_text()))
    assert isinstance(setup.timeline, FrozenFloodTimeline)
    assert type(setup.solver).__name__ == "SnapshotSolver"  # its boundaries are the ingested model's
    with pytest.warns(BreachflowWarning, match="does not respond to the pile"):
        res = run_closure(scen, tmp_path / "run", plots=False)
    assert res.cycles == 2
    for rep in res.reports:
        # t_g = start + (tonnes placed up to cycle g) / capacity: round-the-clock work, no wind record
        t = _placed_tonnes(tmp_path / "run", rep.cycle)
        assert t > 0
        assert rep.operation_time == pytest.approx(3600.0 * (start_h + t / capacity_t_h), rel=1e-9)
        assert rep.flood_level == pytest.approx(3.0, abs=1e-9)  # the demo scene's flood level, held
        assert rep.polder_level == pytest.approx(setup.timeline.polder.initial_level, abs=1e-12)
    plan = json.loads((tmp_path / "run" / "closure_plan.json").read_text())
    assert plan["flood_frozen"] is True and plan["method"] == "barge_crane"
    assert plan["capacity_t_h"] == pytest.approx(capacity_t_h)
    assert plan["start_s"] == pytest.approx(3600.0 * start_h)
    assert plan["placed_t"] == pytest.approx(_placed_tonnes(tmp_path / "run", 2), rel=1e-6)
    assert plan["window"]["open_breach_window_s"] is None
    text = "\n".join(plan_lines(plan))
    assert "held frozen at 3.00 m" in text and "the breach left open is not simulated" in text
    assert "window  none" in text and plan["window"]["fits"] is res.closed
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert "flood held frozen" in man["metadata"]["timeline"]["description"]
    with xr.open_dataset(tmp_path / "run" / "cycle_0002.nc", decode_times=False) as ds:
        assert "flood held frozen" in ds.attrs["closure_timeline_note"]
        assert float(ds["operation_time"].values.item()) == pytest.approx(res.reports[-1].operation_time)




EMBEDDED = BASE.replace('solver = "{solver}"', 'solver = "swe"').replace('snapshots = ["{snap}"]', "")
EMBEDDED = EMBEDDED.replace("[hydro]", '[hydro]\nt_max_initial = "120 s"\nt_max = "30 s"\ntolerance = "2e-3 1/s"')
WINDOW = """
[flood]
surge_height = "3 m"
rise_rate = "0.3 m/hr"
fall_rate = "0.3 m/hr"
[polder]
area = "20 ha"
inundation_depth = "1.5 m"
[breach]
length = "12 m"
depth = "3 m"
wall_slope = 0
mean_velocity = "3 m/s"
"""


def test_embedded_model_with_the_flood_frozen_solves_the_same_flow_on_the_methods_clock(tmp_path):
    """``[closure] flood = "frozen"`` with the embedded solver: the flow solves are exactly those of the same
    run without a method (the levels do not move although [flood] falls and a 20 ha polder would fill within
    the hour), only the operation time is the method's."""
    plain = tmp_path / "plain.toml"
    plain.write_text(EMBEDDED + WINDOW)
    timed = tmp_path / "timed.toml"
    timed.write_text(EMBEDDED.replace("[closure]", '[closure]\nmethod = "barge_crane"\nstart = "6 h"\n'
                                                   'capacity = "150 t/hr"\nflood = "frozen"') + WINDOW)
    a = run_closure(plain, tmp_path / "plain", plots=False)
    b = run_closure(timed, tmp_path / "timed", plots=False)
    assert isinstance(closure_setup(parse_scenario(timed.read_text())).timeline, FrozenFloodTimeline)
    assert a.cycles == b.cycles == 2
    for ra, rb in zip(a.reports, b.reports):
        assert rb.breach_discharge == ra.breach_discharge and rb.max_speed == ra.max_speed
        t = _placed_tonnes(tmp_path / "timed", rb.cycle)
        assert rb.operation_time == pytest.approx(3600.0 * (6.0 + t / 150.0), rel=1e-9)
        assert rb.flood_level == pytest.approx(3.0, abs=1e-12)
    plan = json.loads((tmp_path / "timed" / "closure_plan.json").read_text())
    assert plan["flood_frozen"] is True and '[closure] flood = "frozen"' in plan["flood"]
    # the only window: the report's linear one, Q_D = h_W B v = 3 m x 12 m x 3 m/s = 108 m3/s fills 20 ha
    # 1.5 m deep in 2,778 s (before the flood falling at 0.3 m/h meets it); the closure from 6 h misses it
    assert plan["window"]["open_breach_window_s"] is None
    assert plan["window"]["window_s"] == pytest.approx(1.5 * 20e4 / 108.0, rel=1e-6)
    assert plan["window"]["fits"] is False and b.feasible is False
    assert "report's linear window 0.8 h: does NOT fit" in "\n".join(plan_lines(plan))


@pytest.mark.parametrize("bad, match", [('flood = "held"', r"flood must be one of \('follow', 'frozen'\)"),
                                        ('flood = "frozen"', "needs method")])
def test_closure_flood_key_bad_input(bad, match):
    text = EMBEDDED.replace("[closure]", f"[closure]\n{bad}" + ('\nmethod = "barge_crane"' if "held" in bad else ""))
    with pytest.raises(ParseError, match=r"<input>:\d+: \[closure\] flood: " + match):
        parse_scenario(text + WINDOW)


def test_a_frozen_flood_needs_no_polder_but_a_moving_one_does(tmp_path):
    """The levels held, the polder's area serves only the plan's leakage figure: without [polder] the run is
    set up (a polder of unknown area) and the plan states no polder rise; the flood that follows [flood]
    needs [polder] for the protected side's level."""
    snap = _snapshot(tmp_path)
    text = TIMED.format(solver="snapshot_frozen", snap=snap, start="0 h", capacity="400 t/hr")
    text = text[:text.index("[polder]")]
    with pytest.warns(BreachflowWarning):
        tl = closure_setup(parse_scenario(text)).timeline
    assert isinstance(tl, FrozenFloodTimeline) and tl.polder.area == float("inf")
    moving = EMBEDDED.replace("[closure]", '[closure]\nmethod = "barge_crane"')
    with pytest.raises(InputError, match=r"needs a \[polder\] section"):
        closure_setup(parse_scenario(moving))
    held = moving.replace('method = "barge_crane"', 'method = "barge_crane"\nflood = "frozen"')
    assert closure_setup(parse_scenario(held)).timeline.polder.area == float("inf")
