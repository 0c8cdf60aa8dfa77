"""The closure in time: delivery clock, flood stage, polder balance (independent integrations), the
report's Table 2.5 through the time-coupled path, the [closure] / [polder] keys and the cycle variables."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from breachflow.cycle.delivery import DAY, HOUR, DeliveryClock, delivery_method, delivery_methods
from breachflow.cycle.placement import PlacementPlan
from breachflow.cycle.timeline import FloodStage, Timeline, TimelineSolver, cycle_variables, flood_stage_from_section
from breachflow.errors import InputError, ParseError
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.polder import Polder

TONNE = 1000.0


# --- delivery methods and their clock --------------------------------------------------------------------
def test_builtin_methods_are_registered_with_sourced_defaults():
    assert {"split_barge", "barge_crane", "end_dumping", "cableway", "helicopter"} <= set(delivery_methods.available())
    for name in delivery_methods.available():
        m = delivery_method(name)
        assert m.capacity > 0 and 0 < m.working_hours <= DAY and m.wind_limit > 0 and m.source
    assert delivery_method("end_dumping").positions == ("horizontal",)
    # published figures behind the defaults (t/h)
    assert delivery_method("cableway").capacity * HOUR / TONNE == pytest.approx(300.0)  # Grevelingen
    assert delivery_method("end_dumping").capacity * HOUR / TONNE == pytest.approx(350.0)  # Jones Tract 300-400
    with pytest.raises(InputError, match="unknown delivery method 'zeppelin'"):
        delivery_method("zeppelin")


@pytest.mark.parametrize("hours, tonnes, expected_h", [
    (24, 3500.0, 10.0),              # continuous: 3,500 t at 350 t/h = 10 h
    (12, 3500.0, 10.0),              # 10 h of work fit in the first 12 h working day
    (12, 3500.0 * 2.0, 24.0 + 8.0),  # 20 h of work: 12 h on day 1, 8 h on day 2
    (8, 350.0 * 20, 2 * 24.0 + 4.0),  # 20 h at 8 h/day: days 1 and 2 full, 4 h on day 3
])
def test_clock_spreads_the_work_over_the_working_hours(hours, tonnes, expected_h):
    m = delivery_method("end_dumping", working_hours=hours * HOUR)
    clock = DeliveryClock(m, start=5 * HOUR)
    t = clock.time_after(m.work_time(tonnes * TONNE))
    assert (t - 5 * HOUR) / HOUR == pytest.approx(expected_h, abs=clock.step / HOUR)


def test_clock_waits_for_the_wind_to_fall_below_the_method_limit():
    m = delivery_method("end_dumping")  # 13 m/s, round the clock
    # a storm from 2 h to 7 h after the breach (20 m/s), calm otherwise
    times = np.array([0.0, 2.0, 2.0 + 1e-6, 7.0, 7.0 + 1e-6, 100.0]) * HOUR
    speed = np.array([5.0, 5.0, 20.0, 20.0, 5.0, 5.0])
    clock = DeliveryClock(m, start=1 * HOUR, wind=(times, speed))
    t = clock.time_after(4 * HOUR)  # 1 h before the storm, 3 h after it
    assert t / HOUR == pytest.approx(10.0, abs=2 * clock.step / HOUR)
    ship = DeliveryClock(delivery_method("split_barge"), start=1 * HOUR, wind=(times, speed))  # 25 m/s: no pause
    assert ship.time_after(4 * HOUR) / HOUR == pytest.approx(5.0, abs=2 * ship.step / HOUR)


def test_method_refuses_units_and_positions_it_cannot_place():
    rock = PlacementPlan(diameter=4.0, density=2650.0, positions="line", start=(-1, 0), stop=(1, 0))  # 89 t
    with pytest.raises(InputError, match="handles 1–10 t units"):
        delivery_method("helicopter").check_placement(rock)
    small = PlacementPlan(diameter=1.5, density=2650.0, positions="line", start=(-1, 0), stop=(1, 0))  # 4.7 t
    delivery_method("split_barge").check_placement(small)
    with pytest.raises(InputError, match="end_dumping' places masses by horizontal only"):
        delivery_method("end_dumping").check_placement(small)
    # a material's grading is named as the scenario gave it, with the range its grading reaches (EN 13383's
    # HMA 10000-15000 reaches above 15 t, the split barge's largest unit)
    graded = PlacementPlan(material="HMA_10000_15000", positions="line", start=(-1, 0), stop=(1, 0))
    with pytest.raises(InputError, match=r"\[placement\] material = 'HMA_10000_15000': its grading gives units of "
                                         r"[0-9.]+–(1[5-9]|2[0-9])\.?[0-9]* t, but the delivery method 'split_barge' "
                                         r"handles [0-9.]+–15 t units") as err:
        delivery_method("split_barge").check_placement(graded)
    assert "diameter/density" not in str(err.value)


# --- polder balance against independent integrations -----------------------------------------------------
def _cycle_discharges(n=12, q0=420.0):
    """Breach discharges of a closure that cannot close: masses carried away, the flow barely falls."""
    rng = np.random.default_rng(7)
    return q0 * (1.0 - 0.02 * np.arange(n)) * (1.0 + 0.03 * rng.standard_normal(n))


@pytest.mark.parametrize("area_ha, pump, curve", [(5000.0, 0.0, False), (150.0, 40.0, False), (300.0, 0.0, True),
                                                   (3000.0, 0.0, True)])
def test_polder_level_and_balance_time_follow_an_independent_integration(area_ha, pump, curve):
    """Cycle after cycle the timeline integrates the recorded discharges; scipy integrates the same
    piecewise-constant discharges (dz/dt = (Q - Q_P) / A(z), A(z) analytic for the curve case) with an
    event at the falling flood level: levels and the balance time agree within 1 %."""
    z0, a = 10.0, area_ha * 1e4
    fall = 0.05 / HOUR  # flood falls 5 cm/h from 14 m
    stage = FloodStage(lambda t: 14.0 - fall * t, "linear")
    if curve:  # V(z) = a (z - z0) + k (z - z0)^2: plan area grows with the level, A(z) = a + 2 k (z - z0)
        k = 0.3 * a
        zc = np.linspace(z0, z0 + 6.0, 601)
        pol = Polder(area=a, pump_capacity=pump, initial_level=z0, curve=(zc, a * (zc - z0) + k * (zc - z0) ** 2))
        plan_area = lambda z: a + 2 * k * max(z - z0, 0.0)  # noqa: E731
    else:
        pol = Polder(area=a, pump_capacity=pump, initial_level=z0)
        plan_area = lambda z: a  # noqa: E731
    method = delivery_method("end_dumping")
    tl = Timeline(stage=stage, polder=pol, method=method, start=3 * HOUR, bottom=z0, length=30.0,
                  prestart_discharge=450.0)
    tl.begin()
    qs = _cycle_discharges()
    per_cycle = 700.0 * TONNE  # 2 h of end dumping per cycle
    times, levels, rec_q = [tl.time], [tl.polder_level], [tl.discharge]
    for g, q in enumerate(qs, start=1):
        tl.advance(g * per_cycle)
        times.append(tl.time)
        levels.append(tl.polder_level)
        tl.record(q)
        rec_q.append(q)
    # operation times: start + tonnes / capacity
    np.testing.assert_allclose(np.diff(times), per_cycle / method.capacity, rtol=1e-12)

    # independent: scipy over [0, start] with 450 m3/s, then each interval with the last recorded discharge
    def rhs_of(q):
        return lambda t, z: [(q - pump) / plan_area(z[0])]

    def meets_flood(t, z):
        return z[0] - stage(t)

    meets_flood.terminal = True
    z, t_bal = z0, None
    edges = [0.0] + times
    flows = [450.0] + rec_q[:-1]
    ref = []
    for (t0, t1), q in zip(zip(edges[:-1], edges[1:]), flows):
        if t_bal is None:
            sol = solve_ivp(rhs_of(q), (t0, t1), [z], events=meets_flood, rtol=1e-10, atol=1e-10)
            if sol.t_events[0].size:
                t_bal, z = float(sol.t_events[0][0]), stage(t1)
            else:
                z = float(sol.y[0, -1])
        else:
            z = stage(t1)
        ref.append(z)
    rise = np.array(levels) - z0
    np.testing.assert_allclose(rise, np.array(ref) - z0, rtol=0.01)
    if t_bal is None:
        assert tl.balance_time is None
    else:
        assert tl.balance_time == pytest.approx(t_bal, rel=0.01)
    assert (t_bal is not None) == (area_ha < 1000)  # the small polders meet the flood within the run, the large do not


def test_polder_storage_curve_of_a_flat_polder_is_the_flat_polder():
    flat = Polder(area=2e6, initial_level=1.0)
    zc = np.array([0.0, 1.0, 5.0])
    curved = Polder(area=2e6, initial_level=1.0, curve=(zc, 2e6 * zc))
    for q, dt in ((100.0, 3600.0), (40.0, 7200.0)):
        assert curved.step(1.5, dt, q)[0] == pytest.approx(flat.step(1.5, dt, q)[0], rel=1e-12)
    # 86,400 Q / A m/day: 100 m3/s over 4,900 ha rises 0.176 m/day
    assert Polder(area=4.9e7).rise_per_day(100.0) == pytest.approx(86400 * 100 / 4.9e7, rel=1e-12)


# --- the report's Table 2.5 through the time-coupled path ------------------------------------------------
@pytest.mark.parametrize("fall, t_q, t_i", [("0.4 m/hr", 5.7, 10.0), ("0.06 m/hr", 18.7, 10.0)])
@pytest.mark.parametrize("start_h", [0.0, 1.5, 4.0])
def test_table_2_5_from_the_timeline(fall, t_q, t_i, start_h):
    """800 ha, h_W 2.8 m, Q_D 200 m3/s, Q_P 0, d_I 0.9 m: the report's linear model run through the
    timeline (stage from the [flood] section, polder balance before and during the closure, cycles of
    dumped tonnage) gives t_Q and t_I of Table 2.5 (rounded to 0.1 h; t_I as SPEC §2 corrects it)."""
    sc = parse_scenario(f'[flood]\nsurge_height = "2.8 m"\nfall_rate = "{fall}"\nrise_rate = "{fall}"\n'
                        '[polder]\narea = "800 ha"\ninundation_depth = "90 cm"\n')
    ground = 0.0
    stage = flood_stage_from_section(sc["flood"], ground)
    assert stage(0.0) == pytest.approx(2.8)
    tl = Timeline(stage=stage, polder=sc["polder"].polder(ground), method=delivery_method("split_barge"),
                  start=start_h * HOUR, bottom=ground, length=30.0, prestart_discharge=200.0)
    tl.begin()
    tl.record(200.0)  # Q_D whatever the head: the report's linear discharge model
    inundation, g = None, 0
    while tl.time < 30 * HOUR:
        g += 1
        tl.advance(g * 250.0 * TONNE)  # a split barge of 250 t every 15 min
        if inundation is None and tl.polder_level - ground >= 0.9 - 1e-9:
            inundation = tl.time
        if tl.balance_time is None:
            tl.record(200.0)
    assert tl.balance_time / HOUR == pytest.approx(t_q, abs=0.05)
    # t_I: the polder reaches d_I = 0.9 m at 0.9 / 0.09 h (unless the balance came first); cycles are 15 min
    if t_q > t_i:
        assert inundation / HOUR == pytest.approx(t_i, abs=0.25 + 1e-9)
        assert inundation >= t_i * HOUR - 1e-6


# --- configuration -----------------------------------------------------------------------------------------
CLOSURE = '[closure]\nremap = "porous"\n{extra}\n[polder]\narea = "4900 ha"\npump_capacity = "25 m^3/s"\n'


def test_closure_keys_parse_with_overrides_and_units():
    sc = parse_scenario(CLOSURE.format(extra='method = "split_barge"\nstart = "12 h"\ncapacity = "800 t/hr"\n'
                                             'working_hours = "16 h"\nwind_limit = "ship"\nbreach_date = "2004-06-03T07:50"'))
    keys = sc["closure"].timeline
    assert keys.method == "split_barge" and keys.start == pytest.approx(12 * HOUR)
    assert keys.overrides["capacity"] == pytest.approx(800 * TONNE / HOUR)
    assert keys.overrides["working_hours"] == pytest.approx(16 * HOUR)
    assert keys.overrides["wind_limit"] == pytest.approx(25.0)
    assert sc["polder"].area == pytest.approx(4.9e7) and sc["polder"].pump_capacity == pytest.approx(25.0)
    assert parse_scenario(CLOSURE.format(extra="")).get("closure").timeline.method is None


@pytest.mark.parametrize("extra, key, message", [
    ('method = "zeppelin"', "method", "unknown delivery method"),
    ('start = "12 h"', "start", "needs method"),
    ('method = "split_barge"\ncapacity = "-5 t/hr"', "capacity", "> 0"),
    ('method = "split_barge"\nbreach_date = "yesterday"', "breach_date", "ISO date-time"),
    ('method = "split_barge"\nunit_mass = ["1 t"]', "unit_mass", "lightest, heaviest"),
])
def test_bad_closure_keys_name_the_key_and_line(extra, key, message):
    text = CLOSURE.format(extra=extra)
    with pytest.raises(ParseError, match=message) as exc:
        parse_scenario(text)
    assert f"[closure] {key}" in str(exc.value)
    line = next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith(key + " ="))
    assert exc.value.line == line


def test_placement_rate_is_deprecated_but_still_read():
    with pytest.warns(DeprecationWarning, match=r"\[placement\] rate: deprecated"):
        sc = parse_scenario('[placement]\ndiameter = "1 m"\nrate = "30 1/hr"\n')
    assert sc["placement"].plan.rate == pytest.approx(30 / 3600)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        parse_scenario('[placement]\ndiameter = "1 m"\n')


def test_storage_curve_file_is_read_and_checked(tmp_path):
    good = tmp_path / "storage.csv"
    good.write_text("level [m], volume [hm**3]\n0, 0\n1, 10\n2, 30\n")
    sc = parse_scenario(f'[polder]\narea = "1000 ha"\nstorage_curve = "{good}"\ninitial_level = "0.5 m"\n')
    pol = sc["polder"].polder(ground_level=0.0)
    assert pol.initial_level == 0.5 and pol.plan_area(1.5) == pytest.approx(20e6, rel=1e-6)
    assert pol.level(pol.volume(1.7)) == pytest.approx(1.7, rel=1e-12)
    bad = tmp_path / "bad.csv"
    bad.write_text("level [m], volume [m**3]\n0, 10\n1, 5\n2, 30\n")
    with pytest.raises(ParseError, match="volumes must not decrease"):
        parse_scenario(f'[polder]\narea = "1000 ha"\nstorage_curve = "{bad}"\n')


# --- boundaries and cycle variables ------------------------------------------------------------------------
def test_solver_sets_flood_and_polder_levels_on_the_boundaries():
    from breachflow.cycle.config.timeline import shifted_boundaries
    from breachflow.swe.domain import BoundaryCondition

    base = {"south": [BoundaryCondition.water_level(lambda s: 5.0 - 0.01 * np.asarray(s))],
            "north": [BoundaryCondition.outflow()],
            "west": [BoundaryCondition.outflow(), BoundaryCondition.water_level(5.0, start=-10.0, stop=-2.0)]}
    tl = Timeline(stage=FloodStage(lambda t: 5.0 - 0.1 * t / HOUR), polder=Polder(area=1e6, initial_level=1.0),
                  method=delivery_method("split_barge"))
    solver = TimelineSolver(object(), tl, lambda level: shifted_boundaries(base, level - 5.0))
    dom = SimpleNamespace(y=np.linspace(-300.0, 500.0, 81), bed=np.full((81, 5), 0.5))
    tl.time = 10 * HOUR  # flood at 4.0 m, polder dry: free drainage
    b = solver.boundaries(dom)
    assert b["north"][0].kind == "outflow"
    assert b["south"][0].values("level", np.array([0.0, 100.0]), np.array([0.0]))[0].tolist() == pytest.approx([4.0, 3.0])
    assert float(b["west"][1].level) == pytest.approx(4.0)
    tl.polder_level = 2.5  # polder water 1.5 m deep: the protected side is the polder level
    b = solver.boundaries(dom)
    assert b["north"][0].kind == "level" and float(b["north"][0].level) == 2.5
    # absorbing, with the quarter-wave period of the 800 m span at the 2 m polder depth over the lowest bed
    assert b["north"][0].absorbing == pytest.approx(4.0 * 800.0 / (9.81 * 2.0) ** 0.5, rel=1e-12)
    assert b["west"][0].kind == "level" and b["west"][1].start == -10.0 and float(b["west"][1].level) == pytest.approx(4.0)


def test_cycle_variables_carry_cf_units_and_the_breach_date():
    class Rep:
        flood_level, polder_level, operation_time, breach_discharge = 38.1, 33.2, 7200.0, 812.5

    tl = Timeline(stage=FloodStage.constant(38.1), polder=Polder(area=1e6), method=delivery_method("split_barge"),
                  breach_date=np.datetime64("2004-06-03T07:50", "s"))
    v = cycle_variables(Rep, tl)
    assert v["operation_time"].attrs["units"] == "seconds since 2004-06-03 07:50:00"
    assert float(v["polder_level"]) == 33.2 and v["breach_discharge"].attrs["units"] == "m3 s-1"
    assert cycle_variables(Rep, None)["operation_time"].attrs["units"] == "s"
    tl.time = 2 * DAY + 3 * HOUR
    assert str(tl.datetime) == "2004-06-05T10:50:00"


def test_cold_start_with_a_filled_polder_starts_its_dry_cells_at_the_polder_level():
    from breachflow.swe.domain import BoundaryCondition, uniform_grid

    dom = uniform_grid(0.0, 4.0, -2.0, 2.0, 1.0)
    Y = np.meshgrid(dom.x, dom.y)[1]
    dom.bed = np.where(Y < 0, 0.0, 1.0)
    dom.bed[2, :] = 6.0  # a levee row
    dom.initial_surface = np.where(Y < 0, 5.0, np.nan)
    dom.boundaries = {"south": [BoundaryCondition.water_level(5.0)], "north": [BoundaryCondition.outflow()]}

    class Capture:
        def solve(self, domain, obstacles=None, initial=None):
            self.domain = domain
            return None

    tl = Timeline(stage=FloodStage.constant(5.0), polder=Polder(area=1e6, initial_level=1.0),
                  method=delivery_method("split_barge"))
    tl.polder_level = 3.0
    inner = Capture()
    TimelineSolver(inner, tl, lambda level: dom.boundaries).solve(dom)
    init = inner.domain.initial_surface
    assert np.all(init[Y < 0] == 5.0) and np.all(np.isnan(init[2, :]))  # flood side as it was, levee dry
    assert np.all(init[(Y > 0.5)] == 3.0)  # polder cells at the polder level
    assert inner.domain.boundaries["north"][0].kind == "level"
    TimelineSolver(inner, tl, lambda level: dom.boundaries).solve(dom, initial=object())  # a warm start: untouched
    assert inner.domain.initial_surface is dom.initial_surface or np.array_equal(
        inner.domain.initial_surface, dom.initial_surface, equal_nan=True)


def test_open_breach_weir_is_freads_weir_and_its_window_is_the_balance():
    from breachflow.scenario.discharge import weir_discharge

    tl = Timeline(stage=FloodStage.constant(7.6), polder=Polder(area=4.9e7, initial_level=0.0),
                  method=delivery_method("split_barge"), bottom=0.0, length=61.0, wall_slope=0.5)
    for zp in (0.0, 3.0, 6.5):
        ref = weir_discharge("7.6 m", bottom_width="61 m", wall_slope=0.5, tailwater=f"{zp} m" if zp else None)
        assert tl.weir(0.0, zp) == pytest.approx(ref, rel=1e-9)
    # a constant discharge over a flat polder: balance at h / r_P (independent arithmetic)
    tl.prestart_discharge = 1000.0
    assert tl.open_breach_window() == pytest.approx(7.6 * 4.9e7 / 1000.0, rel=1e-3)
    assert tl.open_breach_window(inundation_depth=2.0) == pytest.approx(2.0 * 4.9e7 / 1000.0, rel=1e-3)
    assert tl.time == 0.0 and tl.polder_level == 0.0  # the state is left as it was
