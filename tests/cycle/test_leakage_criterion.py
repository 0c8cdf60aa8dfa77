"""The closure criterion of what the polder can take: leakage as polder rise per day, against the pumps."""
import math
import warnings

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import CycleContext, criteria
from breachflow.cycle.leakage import PolderLeakage, polder_leakage_check
from breachflow.errors import BreachflowWarning, InputError
from breachflow.field.snapshot import grid_snapshot
from breachflow.scenario.config import parse_scenario

DX = 0.5


def ctx(v=0.1, depth=2.0, q_open=float("nan"), seepage=0.0):
    x = np.arange(41) * DX - 10.0
    y = np.arange(21) * DX - 5.0
    X, _ = np.meshgrid(x, y)
    snap = grid_snapshot(x, y, np.zeros(X.shape), np.full(X.shape, depth), np.zeros(X.shape), np.full(X.shape, v))
    return CycleContext(cycle=1, snapshot=snap, breach_x=(-5.0, 5.0), levee_y=0.0, flood_level=2.0, bottom=0.0,
                        open_breach_discharge=q_open, seepage_discharge=seepage)


def test_polder_rise_and_pumps_by_hand():
    v = polder_leakage_check(11.574074, 1.0e6, 0.0, 0.5)
    assert v.rise_per_day == pytest.approx(1.0, rel=1e-6) and v.net_rise_per_day == v.rise_per_day
    assert not v.acceptable and math.isinf(v.pump_ratio)
    v = polder_leakage_check(11.574074, 1.0e6, 5.0, 0.6)
    assert v.net_rise_per_day == pytest.approx(86400 * 6.574074 / 1e6, rel=1e-9)
    assert v.pump_ratio == pytest.approx(11.574074 / 5.0) and v.acceptable
    assert polder_leakage_check(3.0, 1e6, 4.0, 0.0).acceptable  # the pumps take it all
    with pytest.raises(InputError, match="polder area"):
        polder_leakage_check(1.0, 0.0, 0.0, 0.1)


def test_criterion_on_a_field_with_a_hand_computed_discharge():
    """Uniform h = 2 m, v = 0.1 m/s over the 21 cells (10.5 m) of the section: Q = 2.1 m3/s; over 100 ha that is
    0.18144 m/day; with 2 m3/s of pumps 0.00864 m/day."""
    c = criteria.get("polder_leakage")("0.2 m/day", area="100 ha")
    c.bind_scenario(None)
    r = c.evaluate(ctx())
    assert r.value == pytest.approx(86400 * 2.1 / 1e6) and r.satisfied and r.units == "m day-1"
    assert "2.1 m3/s" in r.description
    assert not criteria.get("polder_leakage")("10 cm/day", area="100 ha", pump_capacity="0 m^3/s").evaluate(ctx()).satisfied
    pumped = criteria.get("polder_leakage")("1 cm/day", area="100 ha", pump_capacity="2 m^3/s").evaluate(ctx())
    assert pumped.value == pytest.approx(86400 * 0.1 / 1e6) and pumped.satisfied


def test_polder_from_the_scenario_and_the_fallback_without_one():
    sc = parse_scenario('[polder]\narea = "50 ha"\ninundation_depth = "1 m"\npump_capacity = "0.5 m^3/s"\n')
    c = PolderLeakage("1 cm/day")
    c.bind_scenario(sc)
    assert c.area == pytest.approx(5e5) and c.pump_capacity == pytest.approx(0.5) and not c.fallback
    bare = PolderLeakage("1 cm/day")
    with pytest.warns(BreachflowWarning, match="seepage_fraction < 0.3"):
        bare.bind_scenario(parse_scenario("[placement]\nbatch = 1\n"))
    # the fallback: seepage / open-breach discharge below 0.3
    r = bare.evaluate(ctx(q_open=10.0, seepage=2.0))
    assert r.name == "seepage_fraction" and r.value == pytest.approx(0.2) and r.satisfied
    assert "fallback" in r.description
    assert not bare.evaluate(ctx(q_open=10.0, seepage=4.0)).satisfied


def test_default_criteria_use_the_polder_when_there_is_one():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)
        s = closure_setup(parse_scenario('[polder]\narea = "100 ha"\ninundation_depth = "1.5 m"\n'
                                         'pump_capacity = "2 m^3/s"\n'))
        names = [c.name for c in s.criteria.items]
        assert names == ["overflow_discharge", "polder_leakage"] and s.criteria.mode == "all"
        pl = s.criteria.items[1]
        assert pl.area == pytest.approx(1e6) and pl.pump_capacity == pytest.approx(2.0) and not pl.fallback
        assert pl.threshold == pytest.approx(0.01)
    with pytest.warns(BreachflowWarning, match="no polder area"):
        s2 = closure_setup(parse_scenario("[placement]\nbatch = 1\n"))
    assert s2.criteria.items[1].fallback


def _dam_ctx(seepage):
    """A dam of 60 resting unit spheres (r = 1 m) in the 10 m gap, flood level 6 m, 2 m of water behind it."""
    c = ctx(v=0.1, depth=2.0, seepage=seepage)
    xs = np.linspace(-4.0, 4.0, 10)
    ys = np.linspace(-2.0, 2.0, 6)
    pos = np.array([(x, y, 1.0) for x in xs for y in ys])
    return CycleContext(cycle=1, snapshot=c.snapshot, breach_x=(-5.0, 5.0), levee_y=0.0, flood_level=6.0, bottom=0.0,
                        pos=pos, radius=np.ones(len(pos)), resting=np.ones(len(pos), bool), seepage_discharge=seepage)


def test_sealed_dam_meets_the_polder_criterion_by_independent_arithmetic():
    from breachflow.swe.porous import forchheimer_coefficients
    from breachflow.materials import get_material
    from breachflow.materials.seal import DEFAULT_SEAL_GRADINGS as D, Grading
    from scipy.optimize import brentq

    c = PolderLeakage("1 cm/day", area="10 ha", seal=["sand", "gravel", "quarry_run"], max_seal_thickness="2 m")
    rock = Grading.from_rock(get_material("HMA_1000_3000"))
    c.bind_rock(rock)
    r = c.evaluate(_dam_ctx(seepage=2.1))          # all of Q = 2.1 m3/s is seepage
    plan = c.seal_plan
    assert r.satisfied and plan is not None, r
    # geometry by hand: bulk volume 60 * 4/3 pi / (1 - 0.38) over 10 m x 6 m; head 6 - 2 m
    L = 60 * 4 / 3 * math.pi / (1 - rock.porosity) / 60.0
    assert plan["flow_path"] == pytest.approx(L) and plan["head"] == pytest.approx(4.0) and plan["height"] == 6.0
    # the leakage after the seal, by solving sum L_k (a_k V + b_k V^2) = H with brentq here
    lays = [(plan["seal_thickness"], D["sand"]), (0.5, D["gravel"]), (0.5, D["quarry_run"]),
            (L - plan["seal_thickness"] - 1.0, rock)]
    def v_of(layers):
        coef = [(t, *forchheimer_coefficients(g.porosity, g.d50)) for t, g in layers]
        return brentq(lambda V: sum(t * (a * V + b * V * V) for t, a, b in coef) - 4.0, 0.0, 100.0, xtol=1e-15)
    ratio = v_of(lays) / v_of([(L, rock)])
    target = 0.01 * 1e5 / 86400
    assert plan["leakage_after"] == pytest.approx(2.1 * ratio, rel=1e-6)
    assert plan["leakage_after"] <= target * (1 + 1e-6)
    assert r.value == pytest.approx(86400 * plan["leakage_after"] / 1e5, rel=1e-9)
    face = 10.0 * 6.0 * math.hypot(1.0, 1.5)
    assert plan["tonnage"]["sand"] == pytest.approx(face * plan["seal_thickness"] * 0.62 * 2650 / 1000)
    assert "sealed by" in r.description and "sand" in r.description
    # overflow the seal cannot stop: Q = 2.1 m3/s with only 1 m3/s through the pile
    assert not c.evaluate(_dam_ctx(seepage=1.0)).satisfied


def test_a_seal_that_would_wash_out_is_refused_when_the_scenario_is_read():
    text = ('[placement]\nmaterial = "HMA_1000_3000"\n[polder]\narea = "100 ha"\ninundation_depth = "1 m"\n'
            '[criteria]\nmode = "all"\noverflow_discharge = "0.5 m^3/s"\n'
            'polder_leakage = { threshold = "1 cm/day", seal = ["sand", "quarry_run"] }\n')
    with pytest.raises(InputError, match=r"sand would wash out through quarry_run: D15_quarry_run/D85_sand = 66.7 > 5"):
        closure_setup(parse_scenario(text))
    ok = text.replace('["sand", "quarry_run"]', '["sand", "gravel", "quarry_run"]')
    s = closure_setup(parse_scenario(ok))
    assert s.criteria.items[1].rock.name == "HMA_1000_3000"
