"""The closure's constants are scenario keys: each changes the result in the direction the physics says, against
arithmetic written out here, and a bad value is refused naming the file, line, key and value."""
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from breachflow.cycle.criteria import EndCriteria
from breachflow.cycle.leakage import FALLBACK_SEEPAGE_FRACTION, PolderLeakage, _rock_grading
from breachflow.cycle.placement import PlacementPlan
from breachflow.cycle.sealing import next_thickness
from breachflow.errors import BreachflowWarning, InputError, ParseError
from breachflow.materials.seal import Grading
from breachflow.scenario.config import parse_scenario


def _fallback(cfg):
    crit = EndCriteria.from_config({"polder_leakage": cfg}).items[0]
    with pytest.warns(BreachflowWarning, match="fallback_fraction"):
        crit.bind_scenario(None)  # no polder: the fallback criterion judges
    return crit


@pytest.mark.parametrize("seepage,q_open", [(25.0, 100.0), (0.9, 4.0), (120.0, 500.0)])
def test_lower_fallback_fraction_refuses_a_dam_the_default_accepts(seepage, q_open):
    ctx = SimpleNamespace(seepage_discharge=seepage, open_breach_discharge=q_open)
    frac = seepage / q_open  # 0.25, 0.225, 0.24: below the default 0.3, above 0.2
    assert frac < FALLBACK_SEEPAGE_FRACTION == 0.3
    default = _fallback({}).evaluate(ctx)
    strict = _fallback({"fallback_fraction": 0.2}).evaluate(ctx)
    assert default.satisfied and not strict.satisfied
    assert default.value == pytest.approx(frac, rel=1e-12) and strict.threshold == 0.2
    # a looser fraction accepts a leakier dam: 40 % of the open breach
    leaky = SimpleNamespace(seepage_discharge=0.4 * q_open, open_breach_discharge=q_open)
    assert not _fallback({}).evaluate(leaky).satisfied
    assert _fallback({"fallback_fraction": 0.5}).evaluate(leaky).satisfied


# a base layer against the dam's rock: D15_rock / D85_base = 45 / 10 = 4.5, D15_rock / D15_base = 45 / 8 = 5.625
BASE = {"name": "base", "d15": "8 mm", "d50": "9 mm", "d85": "10 mm", "porosity": 0.35}
ROCK = Grading("rock", 0.045, 0.08, 0.12, porosity=0.38)


def test_stricter_retention_limit_refuses_a_filter_that_5_accepts():
    PolderLeakage(seal=[BASE]).bind_rock(ROCK)  # 4.5 <= 5: retained
    PolderLeakage(seal=[BASE], retention_limit=4.6).bind_rock(ROCK)
    with pytest.raises(InputError, match=r"base would wash out through rock: .* = 4\.5 > 4\.4"):
        PolderLeakage(seal=[BASE], retention_limit=4.4).bind_rock(ROCK)


def test_stricter_permeability_limit_refuses_a_filter_that_5_accepts():
    PolderLeakage(seal=[BASE]).bind_rock(ROCK)  # 5.625 >= 5: drains
    PolderLeakage(seal=[BASE], permeability_limit=5.6).bind_rock(ROCK)
    with pytest.raises(InputError, match=r"rock does not drain base: .* = 5\.62 < 5\.7"):
        PolderLeakage(seal=[BASE], permeability_limit=5.7).bind_rock(ROCK)
    # a looser limit accepts a rock that the default refuses (D15 36 mm: 36 / 8 = 4.5 < 5)
    finer = Grading("rock", 0.036, 0.08, 0.12, porosity=0.38)
    with pytest.raises(InputError, match="does not drain"):
        PolderLeakage(seal=[BASE]).bind_rock(finer)
    PolderLeakage(seal=[BASE], permeability_limit=4.0).bind_rock(finer)


def test_seal_design_uses_the_limits_of_the_criterion():
    from breachflow.materials.seal import SealDesign

    base = Grading("base", 0.008, 0.009, 0.010)
    with pytest.raises(InputError, match="wash out"):
        SealDesign(base, 0.5, ROCK, retention_limit=4.0)
    d = SealDesign(base, 0.5, ROCK)  # default 5: accepted
    assert d.retention_limit == 5.0 and d.permeability_limit == 5.0


@pytest.mark.parametrize("t,t_max", [(0.5, 2.0), (0.05, 4.0), (1.0, 1.5)])
def test_seal_growth_is_the_smallest_step_between_re_solves(t, t_max):
    target = 2.0
    q = 1.05 * target  # just above the target: 1.1 x 1.05 = 1.155 below the growth factors
    for growth in (1.25, 1.5, 2.0):
        assert next_thickness(t, q, target, t_max, growth) == pytest.approx(min(t_max, growth * t), rel=1e-12)
    # far above the target the leakage ratio governs (1.1 x 3 = 3.3 > 1.25), capped at 8 and at t_max
    assert next_thickness(t, 3 * target, target, t_max, 1.25) == pytest.approx(min(t_max, 3.3 * t), rel=1e-12)
    assert next_thickness(t, 100 * target, target, 1e9, 1.25) == pytest.approx(8 * t, rel=1e-12)
    with pytest.raises(InputError, match="seal_growth must be > 1"):
        PolderLeakage(seal_growth=1.0)


def test_pile_porosity_and_side_slope_of_the_placement():
    spheres = PlacementPlan.from_config({"diameter": "2 m"})
    assert spheres.pile_porosity == 0.40 and spheres.dam_side_slope == 1.5
    k = (math.pi / 6) ** (1 / 3)  # nominal diameter of a 2 m sphere: 2 k
    g = _rock_grading(spheres)
    assert (g.d15, g.d85, g.porosity) == pytest.approx((2 * k, 2 * k, 0.40))
    assert _rock_grading(PlacementPlan.from_config({"diameter": "2 m", "porosity": 0.3})).porosity == 0.3
    rock = PlacementPlan.from_config({"material": "HMA_1000_3000"})
    assert rock.pile_porosity == 0.38 == _rock_grading(rock).porosity  # the grading's own (Rock Manual)
    assert _rock_grading(PlacementPlan.from_config({"material": "HMA_1000_3000", "porosity": 0.33})).porosity == 0.33
    # a mix: tonnage-weighted, concrete cubes 0.45 and bags 0.40 in equal tonnage
    mix = PlacementPlan.from_config({"material": ["concrete_cube", "big_bag"], "fractions": [1, 1]})
    assert mix.pile_porosity == pytest.approx(0.425)


def _trapezoid_volume(B, H, b, m, mw, n=20001):
    """The dam's bulk volume by the trapezoidal rule over its height (independent of the closed form)."""
    z = np.linspace(0.0, H, n)
    f = (b + 2 * m * (H - z)) * (B + 2 * mw * z)
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(z)))


@pytest.mark.parametrize("porosity,side_slope", [(None, None), (0.3, None), (None, 2.5), (0.45, 0.0)])
def test_estimate_takes_the_pile_porosity_and_side_slope(porosity, side_slope):
    from breachflow.cycle.main import _estimate
    from breachflow.scenario.geometry import DEFAULT_WALL_SLOPE

    cfg = {"diameter": "2 m", "density": "2650 kg/m^3"}
    cfg.update({k: v for k, v in (("porosity", porosity), ("side_slope", side_slope)) if v is not None})
    setup = SimpleNamespace(flood_level=5.0, bottom=1.0, breach_x=(10.0, 40.0), placement=PlacementPlan.from_config(cfg))
    e = _estimate(setup, {"metadata": {"initial": {"max_speed": 3.0}}})
    n = 0.40 if porosity is None else porosity
    m = 1.5 if side_slope is None else side_slope
    V = _trapezoid_volume(30.0, 4.0, e.crest_width, m, DEFAULT_WALL_SLOPE)
    assert e.porosity == n and e.side_slope == m
    assert e.tonnage == pytest.approx(2650.0 * (1 - n) * V / 1000.0, rel=1e-6)


def test_bad_values_name_file_line_key_and_value(tmp_path):
    bad = [("[criteria]\npolder_leakage = { fallback_fraction = -0.1 }\n", "fallback_fraction", "-0.1"),
           ("[criteria]\npolder_leakage = { retention_limit = 0 }\n", "retention_limit", "0"),
           ("[criteria]\npolder_leakage = { permeability_limit = \"2 m\" }\n", "permeability_limit", "unit m"),
           ("[criteria]\npolder_leakage = { seal_growth = 0.9 }\n", "seal_growth", "0.9"),
           ("[criteria]\npolder_leakage = { face_slope = -1 }\n", "face_slope", "-1"),
           ("[placement]\ndiameter = \"2 m\"\nporosity = 1.2\n", "porosity", "1.2"),
           ("[placement]\ndiameter = \"2 m\"\nside_slope = -0.5\n", "side_slope", "-0.5")]
    for text, key, value in bad:
        path = tmp_path / "s.toml"
        with pytest.raises((ParseError, InputError)) as exc:
            parse_scenario(text, path)
        msg = str(exc.value)
        assert str(path) in msg and key in msg and value in msg, msg


def test_keys_in_a_scenario_reach_the_criterion_and_the_plan():
    s = parse_scenario("[placement]\ndiameter = \"2 m\"\nporosity = 0.35\nside_slope = 2\n[criteria]\n"
                       "polder_leakage = { fallback_fraction = 0.1, retention_limit = 4, permeability_limit = 6, "
                       "seal_growth = 1.5 }\n")
    crit = s["criteria"].criteria.items[0]
    assert (crit.fallback_fraction, crit.retention_limit, crit.permeability_limit, crit.seal_growth) == (0.1, 4, 6, 1.5)
    plan = s["placement"].plan
    assert (plan.pile_porosity, plan.dam_side_slope) == (0.35, 2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)
        crit.bind_scenario(s)
    assert crit.face_slope == 2.0  # the seal's upstream face follows the dam's side slopes


def test_the_reference_lists_every_key_of_the_criterion_table():
    import inspect

    params = set(inspect.signature(PolderLeakage.__init__).parameters) - {"self"}
    assert set(PolderLeakage.KEYS) == params
    schema = PolderLeakage.option_schema()
    assert schema["fallback_fraction"]["default"] == FALLBACK_SEEPAGE_FRACTION
    assert schema["retention_limit"]["default"] == schema["permeability_limit"]["default"] == 5.0
    assert schema["seal_growth"]["default"] == 1.25
